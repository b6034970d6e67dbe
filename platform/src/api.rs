//! The JSON API under `/api/v1`: the whole worker flow and the admin reads/writes, described
//! by the OpenAPI document at `/api/v1/openapi.json` (generated with utoipa from these
//! handlers).

use axum::Json;
use axum::Router;
use axum::extract::State;
use axum::http::header;
use axum::response::IntoResponse;
use axum::routing::{get, post};
use serde::{Deserialize, Serialize};
use utoipa::{OpenApi, ToSchema};

use crate::AppState;
use crate::admin::Admin;
use crate::dashboard::{self, Dashboard, WorkerRow};
use crate::error::{AppError, ErrorBody, Result};
use crate::export::{self, ExportOptions};
use crate::extract::{ApiJson, ApiPath, ApiQuery};
use crate::flow::{
    self, AnswerAck, AnswerRequest, AssignmentState, Demographics, Handback, ItemRef, QuestionView,
    ReasonsRequest, Source, StartOutcome, StartRequest, TrainingAnswer, TrainingFeedback,
    TrainingResult,
};
use crate::ids::{AssignmentId, LibraryId, StudyId};
use crate::qc::{self, DecisionRecord, RuleOutcome};
use crate::study::{self, MturkMode, PoolSummary, StudySettings};
use crate::study_edit::{self, Edited, FieldChange, SettingsChange, SettingsPatch};
use crate::train::{self, ModelSummary, TrainOptions};

/// The OpenAPI document.
#[derive(OpenApi)]
#[openapi(
    info(title = "Style rating-study platform", version = "1"),
    paths(
        healthz,
        study_info,
        start,
        assignment_state,
        training,
        give_up,
        answer,
        reasons,
        admin_session,
        admin_studies,
        admin_create_study,
        admin_dashboard,
        admin_workers,
        admin_audit,
        admin_qc,
        admin_decision,
        admin_export,
        admin_curated,
        admin_verify_code,
        admin_release,
        admin_models,
        admin_train,
        admin_settings,
        admin_edit_settings,
        admin_settings_changes
    ),
    components(schemas(
        ErrorBody,
        StudyInfo,
        StartRequest,
        StartOutcome,
        Source,
        Demographics,
        AssignmentState,
        QuestionView,
        ItemRef,
        Handback,
        TrainingRequest,
        TrainingAnswer,
        TrainingResult,
        TrainingFeedback,
        AnswerRequest,
        AnswerAck,
        ReasonsRequest,
        OkBody,
        SessionInfo,
        StudySummary,
        CreateStudy,
        Created,
        PoolSummary,
        StudySettings,
        MturkMode,
        Dashboard,
        WorkerRow,
        DecisionRecord,
        QcRequest,
        RuleOutcome,
        DecisionRequest,
        CuratedRequest,
        CuratedCreated,
        CodeCheck,
        ReleaseRequest,
        Released,
        ModelSummary,
        TrainRequest,
        TrainStarted,
        SettingsPatch,
        FieldChange,
        Edited,
        SettingsChange
    ))
)]
pub struct ApiDoc;

/// The worker and admin JSON routes.
pub fn routes() -> Router<AppState> {
    Router::new()
        .route("/healthz", get(healthz))
        .route("/api/v1/openapi.json", get(openapi))
        .route("/api/v1/studies/{study}", get(study_info))
        .route("/api/v1/studies/{study}/start", post(start))
        .route("/api/v1/assignments/{token}", get(assignment_state))
        .route("/api/v1/assignments/{token}/training", post(training))
        .route("/api/v1/assignments/{token}/give-up", post(give_up))
        .route("/api/v1/assignments/{token}/answers", post(answer))
        .route("/api/v1/assignments/{token}/reasons", post(reasons))
        .route("/api/v1/admin/session", get(admin_session))
        .route(
            "/api/v1/admin/studies",
            get(admin_studies).post(admin_create_study),
        )
        .route(
            "/api/v1/admin/studies/{study}/dashboard",
            get(admin_dashboard),
        )
        .route("/api/v1/admin/studies/{study}/workers", get(admin_workers))
        .route("/api/v1/admin/studies/{study}/audit", get(admin_audit))
        .route("/api/v1/admin/studies/{study}/qc", post(admin_qc))
        .route(
            "/api/v1/admin/studies/{study}/assignments/{assignment}/decision",
            post(admin_decision),
        )
        .route(
            "/api/v1/admin/studies/{study}/export/{file}",
            get(admin_export),
        )
        .route("/api/v1/admin/studies/{study}/curated", post(admin_curated))
        .route(
            "/api/v1/admin/studies/{study}/release-abandoned",
            post(admin_release),
        )
        .route(
            "/api/v1/admin/studies/{study}/models",
            get(admin_models).post(admin_train),
        )
        .route(
            "/api/v1/admin/studies/{study}/codes/{code}",
            get(admin_verify_code),
        )
        .route(
            "/api/v1/admin/studies/{study}/settings",
            get(admin_settings).patch(admin_edit_settings),
        )
        .route(
            "/api/v1/admin/studies/{study}/settings/changes",
            get(admin_settings_changes),
        )
        .merge(worker_admin::routes())
}

async fn openapi() -> Json<utoipa::openapi::OpenApi> {
    Json(ApiDoc::openapi().merge_from(worker_admin::Doc::openapi()))
}

/// A plain acknowledgement.
#[derive(Debug, Serialize, ToSchema)]
pub struct OkBody {
    /// Always true.
    pub ok: bool,
}

/// Answers 200 when the database is reachable.
#[utoipa::path(get, path = "/healthz", responses((status = 200, body = OkBody), (status = 503, body = ErrorBody)))]
async fn healthz(State(state): State<AppState>) -> impl IntoResponse {
    match state.db.ping().await {
        Ok(()) => (axum::http::StatusCode::OK, Json(OkBody { ok: true })).into_response(),
        Err(_) => (
            axum::http::StatusCode::SERVICE_UNAVAILABLE,
            Json(ErrorBody {
                error: "database unreachable".into(),
            }),
        )
            .into_response(),
    }
}

/// What a worker may know about a study.
#[derive(Debug, Serialize, ToSchema)]
pub struct StudyInfo {
    /// Id.
    pub id: StudyId,
    /// Name.
    pub name: String,
    /// Description.
    pub description: String,
    /// Questions per HIT.
    pub questions_per_hit: u32,
    /// Training questions.
    pub training_questions: u32,
    /// MTurk mode.
    pub mturk_mode: MturkMode,
}

/// Public description of a study.
#[utoipa::path(get, path = "/api/v1/studies/{study}", params(("study" = i64, Path)),
    responses((status = 200, body = StudyInfo), (status = 404, body = ErrorBody)))]
async fn study_info(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<StudyInfo>> {
    let s = study::load(&state.db, id).await?;
    Ok(Json(StudyInfo {
        id: s.id,
        name: s.name,
        description: s.settings.description.clone(),
        questions_per_hit: s.settings.questions_per_hit,
        training_questions: s.settings.training_questions,
        mturk_mode: s.settings.mturk_mode,
    }))
}

/// Starts or resumes an assignment (MTurk preview creates nothing).
#[utoipa::path(post, path = "/api/v1/studies/{study}/start", params(("study" = i64, Path)),
    request_body = StartRequest,
    responses((status = 200, body = StartOutcome), (status = 400, body = ErrorBody),
              (status = 403, body = ErrorBody), (status = 409, body = ErrorBody)))]
async fn start(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    ApiJson(req): ApiJson<StartRequest>,
) -> Result<Json<StartOutcome>> {
    let s = study::load(&state.db, id).await?;
    Ok(Json(flow::start(&state.db, &s, req).await?))
}

/// The assignment's state: the single source of truth for resuming.
#[utoipa::path(get, path = "/api/v1/assignments/{token}", params(("token" = String, Path)),
    responses((status = 200, body = AssignmentState), (status = 404, body = ErrorBody)))]
async fn assignment_state(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
) -> Result<Json<AssignmentState>> {
    let a = flow::by_token(&state.db, &token).await?;
    let s = flow::study_of(&state.db, &a).await?;
    Ok(Json(flow::state(&state.db, &s, &a).await?))
}

/// A training attempt.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TrainingRequest {
    /// One answer per training question.
    pub answers: Vec<TrainingAnswer>,
}

/// Submits a training attempt; feedback per question.
#[utoipa::path(post, path = "/api/v1/assignments/{token}/training", params(("token" = String, Path)),
    request_body = TrainingRequest,
    responses((status = 200, body = TrainingResult), (status = 400, body = ErrorBody), (status = 409, body = ErrorBody)))]
async fn training(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    ApiJson(req): ApiJson<TrainingRequest>,
) -> Result<Json<TrainingResult>> {
    if req.answers.len() > 100 {
        return Err(AppError::BadRequest("answers: too many".into()));
    }
    let a = flow::by_token(&state.db, &token).await?;
    let s = flow::study_of(&state.db, &a).await?;
    Ok(Json(
        flow::submit_training(&state.db, &s, &a, &req.answers).await?,
    ))
}

/// Gives up the training (screen-out code, not a rejection).
#[utoipa::path(post, path = "/api/v1/assignments/{token}/give-up", params(("token" = String, Path)),
    responses((status = 200, body = AssignmentState), (status = 409, body = ErrorBody)))]
async fn give_up(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
) -> Result<Json<AssignmentState>> {
    let a = flow::by_token(&state.db, &token).await?;
    flow::give_up(&state.db, &a).await?;
    let a = flow::by_token(&state.db, &token).await?;
    let s = flow::study_of(&state.db, &a).await?;
    Ok(Json(flow::state(&state.db, &s, &a).await?))
}

/// Stores an answer durably before acknowledging it; idempotent.
#[utoipa::path(post, path = "/api/v1/assignments/{token}/answers", params(("token" = String, Path)),
    request_body = AnswerRequest,
    responses((status = 200, body = AnswerAck), (status = 400, body = ErrorBody),
              (status = 404, body = ErrorBody), (status = 409, body = ErrorBody)))]
async fn answer(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    ApiJson(req): ApiJson<AnswerRequest>,
) -> Result<Json<AnswerAck>> {
    Ok(Json(flow::answer(&state.db, &token, &req).await?))
}

/// Stores the "why did you choose?" questionnaire of a question.
#[utoipa::path(post, path = "/api/v1/assignments/{token}/reasons", params(("token" = String, Path)),
    request_body = ReasonsRequest,
    responses((status = 200, body = OkBody), (status = 400, body = ErrorBody), (status = 409, body = ErrorBody)))]
async fn reasons(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    ApiJson(req): ApiJson<ReasonsRequest>,
) -> Result<Json<OkBody>> {
    let a = flow::by_token(&state.db, &token).await?;
    flow::submit_reasons(&state.db, &a, &req).await?;
    Ok(Json(OkBody { ok: true }))
}

/// The logged-in admin and the CSRF token to send as `x-csrf-token`.
#[derive(Debug, Serialize, ToSchema)]
pub struct SessionInfo {
    /// Username.
    pub username: String,
    /// CSRF token.
    pub csrf: String,
}

/// Who is logged in (session cookie required).
#[utoipa::path(get, path = "/api/v1/admin/session",
    responses((status = 200, body = SessionInfo), (status = 401, body = ErrorBody)))]
async fn admin_session(admin: Admin) -> Json<SessionInfo> {
    Json(SessionInfo {
        username: admin.username,
        csrf: admin.csrf,
    })
}

/// A study in the admin list.
#[derive(Debug, Serialize, ToSchema)]
pub struct StudySummary {
    /// Id.
    pub id: StudyId,
    /// Name.
    pub name: String,
    /// Library.
    pub library: LibraryId,
    /// Settings.
    pub settings: StudySettings,
}

/// All studies.
#[utoipa::path(get, path = "/api/v1/admin/studies",
    responses((status = 200, body = Vec<StudySummary>), (status = 401, body = ErrorBody)))]
async fn admin_studies(
    _admin: Admin,
    State(state): State<AppState>,
) -> Result<Json<Vec<StudySummary>>> {
    Ok(Json(
        study::list(&state.db)
            .await?
            .into_iter()
            .map(|s| StudySummary {
                id: s.id,
                name: s.name,
                library: s.library,
                settings: s.settings,
            })
            .collect(),
    ))
}

/// A new study.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CreateStudy {
    /// Name.
    pub name: String,
    /// Library name.
    pub library: String,
    /// Settings (missing fields take the paper's defaults).
    #[serde(default)]
    pub settings: StudySettings,
}

/// The created study.
#[derive(Debug, Serialize, ToSchema)]
pub struct Created {
    /// Id.
    pub id: StudyId,
    /// Generated tuples.
    pub pool: PoolSummary,
}

/// Creates a study (CSRF header required).
#[utoipa::path(post, path = "/api/v1/admin/studies", request_body = CreateStudy,
    responses((status = 200, body = Created), (status = 400, body = ErrorBody),
              (status = 401, body = ErrorBody), (status = 403, body = ErrorBody)))]
async fn admin_create_study(
    _admin: Admin,
    State(state): State<AppState>,
    ApiJson(req): ApiJson<CreateStudy>,
) -> Result<Json<Created>> {
    let row = sqlx::query("SELECT id FROM libraries WHERE name = $1")
        .bind(&req.library)
        .fetch_optional(&state.db.pool)
        .await?
        .ok_or_else(|| AppError::BadRequest(format!("no library named {:?}", req.library)))?;
    let library = LibraryId(sqlx::Row::try_get(&row, "id")?);
    let (id, pool) = study::create(&state.db, &req.name, library, req.settings).await?;
    Ok(Json(Created { id, pool }))
}

/// Dashboard numbers.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/dashboard", params(("study" = i64, Path)),
    responses((status = 200, body = Dashboard), (status = 401, body = ErrorBody)))]
async fn admin_dashboard(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<Dashboard>> {
    let s = study::load(&state.db, id).await?;
    Ok(Json(dashboard::compute(&state.db, &s).await?.0))
}

/// The study's trained style metrics, newest first (status, λ, accuracy; the report is at
/// `/admin/studies/{study}/models/{id}/report/`).
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/models", params(("study" = i64, Path)),
    responses((status = 200, body = Vec<ModelSummary>), (status = 401, body = ErrorBody)))]
async fn admin_models(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<Vec<ModelSummary>>> {
    study::load(&state.db, id).await?;
    Ok(Json(train::list(&state.db, id).await?))
}

/// Training options (all optional).
#[derive(Debug, Default, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TrainRequest {
    /// λ of eq. 5.8; omitted: chosen by cross-validation.
    pub lambda: Option<f64>,
    /// Cross-validation folds (default 5).
    pub folds: Option<usize>,
}

/// A training started in the background.
#[derive(Debug, Serialize, ToSchema)]
pub struct TrainStarted {
    /// The model being trained; poll `GET …/models` for its status.
    pub id: crate::ids::ModelId,
}

/// Starts fitting the style metric on the study's answers (CSRF header required). Returns at
/// once; 409 when there are no answers yet or a training is already running.
#[utoipa::path(post, path = "/api/v1/admin/studies/{study}/models", params(("study" = i64, Path)),
    request_body = TrainRequest,
    responses((status = 202, body = TrainStarted), (status = 400, body = ErrorBody),
        (status = 401, body = ErrorBody), (status = 403, body = ErrorBody),
        (status = 409, body = ErrorBody)))]
async fn admin_train(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    ApiJson(req): ApiJson<TrainRequest>,
) -> Result<impl IntoResponse> {
    let s = study::load(&state.db, id).await?;
    let opts = TrainOptions {
        lambda: req.lambda,
        folds: req.folds.unwrap_or(TrainOptions::default().folds),
    };
    let model = train::start(&state.db, &s, opts).await?;
    Ok((
        axum::http::StatusCode::ACCEPTED,
        Json(TrainStarted { id: model }),
    ))
}

/// Per-worker table.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/workers", params(("study" = i64, Path)),
    responses((status = 200, body = Vec<WorkerRow>), (status = 401, body = ErrorBody)))]
async fn admin_workers(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<Vec<WorkerRow>>> {
    let s = study::load(&state.db, id).await?;
    Ok(Json(dashboard::compute(&state.db, &s).await?.1))
}

/// Audit trail of decisions.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/audit", params(("study" = i64, Path)),
    responses((status = 200, body = Vec<DecisionRecord>), (status = 401, body = ErrorBody)))]
async fn admin_audit(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<Vec<DecisionRecord>>> {
    study::load(&state.db, id).await?;
    Ok(Json(qc::audit(&state.db, id).await?))
}

/// Re-evaluating the control rule.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct QcRequest {
    /// Reject at this many control errors (default: the study's setting).
    pub threshold: Option<u32>,
    /// Only report what would change.
    pub dry_run: bool,
}

/// Dry-runs or applies the control rule (CSRF header required).
#[utoipa::path(post, path = "/api/v1/admin/studies/{study}/qc", params(("study" = i64, Path)),
    request_body = QcRequest,
    responses((status = 200, body = Vec<RuleOutcome>), (status = 401, body = ErrorBody), (status = 403, body = ErrorBody)))]
async fn admin_qc(
    admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    ApiJson(req): ApiJson<QcRequest>,
) -> Result<Json<Vec<RuleOutcome>>> {
    let s = study::load(&state.db, id).await?;
    let threshold = req.threshold.unwrap_or(s.settings.reject_at_control_errors);
    Ok(Json(
        qc::evaluate(
            &state.db,
            id,
            threshold,
            !req.dry_run,
            &format!("admin:{}", admin.username),
        )
        .await?,
    ))
}

/// An override.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct DecisionRequest {
    /// `approved` or `rejected`.
    pub decision: String,
}

/// Overrides one assignment's decision (CSRF header required; audited).
#[utoipa::path(post, path = "/api/v1/admin/studies/{study}/assignments/{assignment}/decision",
    params(("study" = i64, Path), ("assignment" = i64, Path)), request_body = DecisionRequest,
    responses((status = 200, body = OkBody), (status = 401, body = ErrorBody), (status = 403, body = ErrorBody)))]
async fn admin_decision(
    admin: Admin,
    State(state): State<AppState>,
    ApiPath((id, assignment)): ApiPath<(StudyId, AssignmentId)>,
    ApiJson(req): ApiJson<DecisionRequest>,
) -> Result<Json<OkBody>> {
    qc::override_decision(&state.db, id, assignment, &req.decision, &admin.username).await?;
    Ok(Json(OkBody { ok: true }))
}

/// One export file (`triplets.csv`, `reasons.csv`, `workers.csv`, `assignments.csv`,
/// `bonuses.csv`, `mturk_decisions.csv`, `mturk_bonuses.csv`, `prolific_bonuses.csv`,
/// `external_question.xml`, `manifest.json`). The options apply to the analysis files alike;
/// the payment files list every completed MTurk HIT and every bonus, and are refused (400) in
/// a pseudonymous export. The manifest's notes say what each option does to each file.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/export/{file}",
    params(("study" = i64, Path), ("file" = String, Path), ExportOptions),
    responses((status = 200, body = String), (status = 400, body = ErrorBody),
              (status = 401, body = ErrorBody), (status = 404, body = ErrorBody)))]
async fn admin_export(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath((id, file)): ApiPath<(StudyId, String)>,
    ApiQuery(opts): ApiQuery<ExportOptions>,
) -> Result<impl IntoResponse> {
    export_file(&state, id, &file, opts).await
}

/// Serves one export file (shared by the API and the admin pages).
pub async fn export_file(
    state: &AppState,
    id: StudyId,
    file: &str,
    opts: ExportOptions,
) -> Result<impl IntoResponse + use<>> {
    if !export::FILES.contains(&file) {
        return Err(AppError::NotFound("export file"));
    }
    let s = study::load(&state.db, id).await?;
    let (name, bytes) = export::file(&state.db, &s, file, opts, &state.settings.public_url).await?;
    let mime = if name.ends_with(".csv") {
        "text/csv; charset=utf-8"
    } else if name.ends_with(".xml") {
        "application/xml"
    } else {
        "application/json"
    };
    Ok((
        [
            (header::CONTENT_TYPE, mime.to_string()),
            (
                header::CONTENT_DISPOSITION,
                format!("attachment; filename=\"study-{id}-{name}\""),
            ),
        ],
        bytes,
    ))
}

/// A curated control or training triplet, by item names; `b` is the expected answer.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CuratedRequest {
    /// `control` or `training`.
    pub kind: String,
    /// Reference item name.
    pub a: String,
    /// The item closer in style to `a` (the expected answer).
    pub b: String,
    /// The other item.
    pub c: String,
}

/// The stored curated triplet.
#[derive(Debug, Serialize, ToSchema)]
pub struct CuratedCreated {
    /// Tuple id.
    pub id: crate::ids::TupleId,
}

/// Adds a curated control or training triplet (CSRF header required).
#[utoipa::path(post, path = "/api/v1/admin/studies/{study}/curated", params(("study" = i64, Path)),
    request_body = CuratedRequest,
    responses((status = 200, body = CuratedCreated), (status = 400, body = ErrorBody),
              (status = 401, body = ErrorBody), (status = 403, body = ErrorBody)))]
async fn admin_curated(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    ApiJson(req): ApiJson<CuratedRequest>,
) -> Result<Json<CuratedCreated>> {
    let s = study::load(&state.db, id).await?;
    let tuple = study::add_curated(&state.db, &s, &req.kind, [&req.a, &req.b, &req.c]).await?;
    Ok(Json(CuratedCreated { id: tuple }))
}

/// Which assignment a completion code belongs to.
#[derive(Debug, Serialize, ToSchema)]
pub struct CodeCheck {
    /// Whether the code is a valid completion code of this study.
    pub valid: bool,
    /// The assignment it belongs to.
    pub assignment: Option<AssignmentId>,
}

/// Checks a completion code a worker submitted.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/codes/{code}",
    params(("study" = i64, Path), ("code" = String, Path)),
    responses((status = 200, body = CodeCheck), (status = 401, body = ErrorBody)))]
async fn admin_verify_code(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath((id, code)): ApiPath<(StudyId, String)>,
) -> Result<Json<CodeCheck>> {
    if code.len() > 64 {
        return Err(AppError::BadRequest("code: at most 64 characters".into()));
    }
    let s = study::load(&state.db, id).await?;
    let assignment = flow::verify_code(&state.db, &s, &code).await?;
    Ok(Json(CodeCheck {
        valid: assignment.is_some(),
        assignment,
    }))
}

/// Expiring abandoned assignments.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ReleaseRequest {
    /// Expire assignments started at least this many minutes ago that are not finished.
    pub older_than_minutes: u32,
}

/// How many assignments were expired.
#[derive(Debug, Serialize, ToSchema)]
pub struct Released {
    /// Expired assignments (their unanswered slots are free again).
    pub released: usize,
}

/// Expires abandoned assignments and frees their unanswered slots (CSRF header required).
#[utoipa::path(post, path = "/api/v1/admin/studies/{study}/release-abandoned",
    params(("study" = i64, Path)), request_body = ReleaseRequest,
    responses((status = 200, body = Released), (status = 401, body = ErrorBody), (status = 403, body = ErrorBody)))]
async fn admin_release(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    ApiJson(req): ApiJson<ReleaseRequest>,
) -> Result<Json<Released>> {
    study::load(&state.db, id).await?;
    let released =
        flow::release_abandoned(&state.db, id, i64::from(req.older_than_minutes) * 60_000).await?;
    Ok(Json(Released { released }))
}

/// The study's current settings.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/settings", params(("study" = i64, Path)),
    responses((status = 200, body = StudySettings), (status = 401, body = ErrorBody),
              (status = 404, body = ErrorBody)))]
async fn admin_settings(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<StudySettings>> {
    Ok(Json(study::load(&state.db, id).await?.settings))
}

/// Changes some of a study's settings (CSRF header required; every changed field is audited).
/// The description, `max_training_attempts`, `reasons_probability`,
/// `reject_at_control_errors`, the Prolific codes, `blocked_workers` and `exclude_workers_of`
/// may change at any time and apply from the next start, HIT or completion on;
/// `questions_per_hit`, `controls_per_hit` and `mturk_mode` only while the study has no
/// assignment; `tuples`, `replication`, `seed` and `training_questions` never (the stored pool
/// was built from them). A field sent with its current value is no change. Refusals are 409
/// with the field and the reason; invalid values 400.
#[utoipa::path(patch, path = "/api/v1/admin/studies/{study}/settings", params(("study" = i64, Path)),
    request_body = SettingsPatch,
    responses((status = 200, body = Edited), (status = 400, body = ErrorBody),
              (status = 401, body = ErrorBody), (status = 403, body = ErrorBody),
              (status = 404, body = ErrorBody), (status = 409, body = ErrorBody)))]
async fn admin_edit_settings(
    admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    ApiJson(patch): ApiJson<SettingsPatch>,
) -> Result<Json<Edited>> {
    Ok(Json(
        study_edit::edit(&state.db, id, &patch, &format!("admin:{}", admin.username)).await?,
    ))
}

/// The study's settings changes (who, when, old and new value), newest first.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/settings/changes", params(("study" = i64, Path)),
    responses((status = 200, body = Vec<SettingsChange>), (status = 401, body = ErrorBody),
              (status = 404, body = ErrorBody)))]
async fn admin_settings_changes(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<Vec<SettingsChange>>> {
    study::load(&state.db, id).await?;
    Ok(Json(study_edit::changes(&state.db, id).await?))
}

/// Managing a worker from the dashboard: block or unblock them by their crowd platform id, and
/// record bonuses (the study page's worker rows post the same operations as forms). One
/// self-contained section with its own OpenAPI fragment, merged into [`ApiDoc`].
mod worker_admin {
    use axum::Json;
    use axum::Router;
    use axum::extract::State;
    use axum::routing::{get, post};
    use serde::Deserialize;
    use utoipa::{OpenApi, ToSchema};

    use crate::AppState;
    use crate::admin::Admin;
    use crate::bonus::{self, BonusRecord};
    use crate::error::{AppError, ErrorBody, Result};
    use crate::extract::{ApiJson, ApiPath};
    use crate::ids::{AssignmentId, StudyId};
    use crate::study;
    use crate::study_edit::{self, BlockOutcome};

    #[derive(OpenApi)]
    #[openapi(
        paths(admin_block, admin_add_bonus, admin_bonuses),
        components(schemas(BlockRequest, BlockOutcome, BonusRequest, BonusRecord))
    )]
    pub(super) struct Doc;

    pub(super) fn routes() -> Router<AppState> {
        Router::new()
            .route(
                "/api/v1/admin/studies/{study}/assignments/{assignment}/block",
                post(admin_block),
            )
            .route(
                "/api/v1/admin/studies/{study}/assignments/{assignment}/bonuses",
                post(admin_add_bonus),
            )
            .route("/api/v1/admin/studies/{study}/bonuses", get(admin_bonuses))
    }

    /// Blocking or unblocking the worker of an assignment.
    #[derive(Debug, Deserialize, ToSchema)]
    #[serde(deny_unknown_fields)]
    pub(super) struct BlockRequest {
        /// `true`: put the worker's platform id on the block list (their open HIT in the study
        /// ends); `false`: take it off.
        blocked: bool,
    }

    /// Blocks or unblocks the worker of an assignment by their crowd platform id (CSRF header
    /// required; audited as a change of `blocked_workers`).
    #[utoipa::path(post, path = "/api/v1/admin/studies/{study}/assignments/{assignment}/block",
        params(("study" = i64, Path), ("assignment" = i64, Path)), request_body = BlockRequest,
        responses((status = 200, body = BlockOutcome), (status = 400, body = ErrorBody),
            (status = 401, body = ErrorBody), (status = 403, body = ErrorBody),
            (status = 404, body = ErrorBody)))]
    async fn admin_block(
        admin: Admin,
        State(state): State<AppState>,
        ApiPath((id, assignment)): ApiPath<(StudyId, AssignmentId)>,
        ApiJson(req): ApiJson<BlockRequest>,
    ) -> Result<Json<BlockOutcome>> {
        let actor = format!("admin:{}", admin.username);
        Ok(Json(
            study_edit::block_worker_of(&state.db, id, assignment, req.blocked, &actor).await?,
        ))
    }

    /// A bonus for the worker of an assignment.
    #[derive(Debug, Deserialize, ToSchema)]
    #[serde(deny_unknown_fields)]
    pub(super) struct BonusRequest {
        /// The amount with at most two decimals, as a string (`"1.50"`) or a number; at most
        /// 100.00. MTurk pays US dollars, Prolific the study's currency.
        #[schema(value_type = String, example = "1.50")]
        amount: serde_json::Value,
        /// The reason the worker is shown (one line, at most 500 characters).
        reason: String,
    }

    /// Records a bonus for the worker of a finished HIT (CSRF header required; stored with who
    /// and when). Nothing is paid: the exports `mturk_bonuses.csv` and `prolific_bonuses.csv`
    /// list the bonuses in the formats the platforms are paid with. 409 while the HIT is open.
    #[utoipa::path(post, path = "/api/v1/admin/studies/{study}/assignments/{assignment}/bonuses",
        params(("study" = i64, Path), ("assignment" = i64, Path)), request_body = BonusRequest,
        responses((status = 200, body = BonusRecord), (status = 400, body = ErrorBody),
            (status = 401, body = ErrorBody), (status = 403, body = ErrorBody),
            (status = 404, body = ErrorBody), (status = 409, body = ErrorBody)))]
    async fn admin_add_bonus(
        admin: Admin,
        State(state): State<AppState>,
        ApiPath((id, assignment)): ApiPath<(StudyId, AssignmentId)>,
        ApiJson(req): ApiJson<BonusRequest>,
    ) -> Result<Json<BonusRecord>> {
        let amount = match &req.amount {
            serde_json::Value::String(s) => s.clone(),
            serde_json::Value::Number(n) => n.to_string(),
            _ => {
                return Err(AppError::BadRequest(
                    "amount: an amount like \"1.50\"".into(),
                ));
            }
        };
        let cents = bonus::parse_amount(&amount)?;
        let actor = format!("admin:{}", admin.username);
        Ok(Json(
            bonus::record(&state.db, id, assignment, cents, &req.reason, &actor).await?,
        ))
    }

    /// The study's recorded bonuses, newest first.
    #[utoipa::path(get, path = "/api/v1/admin/studies/{study}/bonuses",
        params(("study" = i64, Path)),
        responses((status = 200, body = Vec<BonusRecord>), (status = 401, body = ErrorBody),
            (status = 404, body = ErrorBody)))]
    async fn admin_bonuses(
        _admin: Admin,
        State(state): State<AppState>,
        ApiPath(id): ApiPath<StudyId>,
    ) -> Result<Json<Vec<BonusRecord>>> {
        study::load(&state.db, id).await?;
        Ok(Json(bonus::list(&state.db, id).await?))
    }
}
