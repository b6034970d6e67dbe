//! Admin reads over JSON: the session, the studies (and creating one), the dashboard, the
//! per-worker table, the audit trail, completion codes and the export files. Every route
//! takes the session cookie; creating a study, being a state change, also the CSRF header
//! (see [`crate::web::admin`] and the `securitySchemes` of the document).

use axum::Json;
use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::IntoResponse;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::AppState;
use crate::error::{AppError, ErrorBody, Result};
use crate::flow;
use crate::flow::qc::{self, DecisionRecord};
use crate::store::ids::{AssignmentId, LibraryId, StudyId};
use crate::studies::dashboard::{self, Dashboard, WorkerRow};
use crate::studies::export::{self, ExportOptions};
use crate::studies::study::{self, PoolSummary, StudySettings, StudyStatus};
use crate::web::admin::Admin;
use crate::web::extract::{ApiJson, ApiPath, ApiQuery};

/// The logged-in admin and the CSRF token to send as `x-csrf-token`.
#[derive(Debug, Serialize, ToSchema)]
pub struct SessionInfo {
    /// Username.
    pub username: String,
    /// CSRF token.
    pub csrf: String,
}

/// Who is logged in, and the session's CSRF token.
#[utoipa::path(get, path = "/api/v1/admin/session", responses((status = 200, body = SessionInfo)))]
pub(super) async fn admin_session(admin: Admin) -> Json<SessionInfo> {
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
    /// Whether its tuple pool is complete (`creating`: workers cannot start yet).
    pub status: StudyStatus,
}

/// All studies.
#[utoipa::path(get, path = "/api/v1/admin/studies",
    responses((status = 200, body = Vec<StudySummary>)))]
pub(super) async fn admin_studies(
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
                status: s.status,
            })
            .collect(),
    ))
}

/// A new study.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CreateStudy {
    /// Name.
    #[schema(min_length = 1, max_length = 200)]
    pub name: String,
    /// Library name.
    #[schema(min_length = 1, max_length = 200)]
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
    /// `ready` (200), or `creating` (202) while the pool is still being written.
    pub status: StudyStatus,
    /// Rows (tuples and slots) of the pool written.
    pub rows_done: i64,
    /// Rows of the whole pool.
    pub rows_total: i64,
    /// What the pool lacks against the settings (no hidden controls, no practice questions…),
    /// in plain words; empty when nothing.
    pub warnings: Vec<String>,
}

/// Creates a study and its tuple pool. The pool is written in chunks that leave the answer
/// path free; a request waits up to 2 s for it (200, `ready`), and a larger pool goes on in
/// the background (202, `creating`: `GET /api/v1/admin/studies/{study}` shows its progress,
/// and workers can start once it is `ready`).
#[utoipa::path(post, path = "/api/v1/admin/studies", request_body = CreateStudy,
    responses((status = 200, description = "The study, its pool complete", body = Created),
              (status = 202, description = "The study, its pool still being written",
                  body = Created),
              (status = 400, description = "No library of that name, too few items, more tuples \
                  than the library has distinct triplets, more than 20,000,000 slots, or an \
                  invalid field (the message names it)", body = ErrorBody)))]
pub(super) async fn admin_create_study(
    _admin: Admin,
    State(state): State<AppState>,
    ApiJson(req): ApiJson<CreateStudy>,
) -> Result<(StatusCode, Json<Created>)> {
    let row = sqlx::query("SELECT id FROM libraries WHERE name = $1")
        .bind(&req.library)
        .fetch_optional(&state.db.pool)
        .await?
        .ok_or_else(|| AppError::BadRequest(format!("no library named {:?}", req.library)))?;
    let library = LibraryId(sqlx::Row::try_get(&row, "id")?);
    let started = study::start_creation(
        &state.db,
        &req.name,
        library,
        req.settings,
        study::CREATE_WAIT,
    )
    .await?;
    let s = study::load(&state.db, started.id).await?;
    let code = if started.ready {
        StatusCode::OK
    } else {
        StatusCode::ACCEPTED
    };
    Ok((
        code,
        Json(Created {
            id: started.id,
            pool: started.summary,
            status: s.status,
            rows_done: s.progress.rows_done,
            rows_total: s.progress.rows_total,
            warnings: started.warnings,
        }),
    ))
}

/// A study: settings, where its tuple pool stands, and what the pool lacks.
#[derive(Debug, Serialize, ToSchema)]
pub struct StudyDetail {
    /// Id.
    pub id: StudyId,
    /// Name.
    pub name: String,
    /// Library.
    pub library: LibraryId,
    /// Settings.
    pub settings: StudySettings,
    /// `creating` while the pool is written (workers cannot start), `ready`, or `failed`.
    pub status: StudyStatus,
    /// Rows (tuples and slots) of the pool written; while a failed study's rows are deleted,
    /// the rows left.
    pub rows_done: i64,
    /// Rows of the whole pool (0 for studies created before progress was recorded).
    pub rows_total: i64,
    /// When the last part of the pool was written (Unix ms).
    pub updated_at: Option<i64>,
    /// Why the creation failed.
    pub error: Option<String>,
    /// What the pool lacks against the settings, in plain words; empty when nothing.
    pub warnings: Vec<String>,
}

/// One study, with the progress of its tuple pool and its warnings.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}", params(("study" = i64, Path)),
    responses((status = 200, body = StudyDetail)))]
pub(super) async fn admin_study(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<StudyDetail>> {
    let s = study::load(&state.db, id).await?;
    let warnings = study::warnings(&state.db, &s).await?;
    Ok(Json(StudyDetail {
        id: s.id,
        name: s.name,
        library: s.library,
        settings: s.settings,
        status: s.status,
        rows_done: s.progress.rows_done,
        rows_total: s.progress.rows_total,
        updated_at: s.progress.updated_at,
        error: s.progress.error,
        warnings,
    }))
}

/// Dashboard numbers.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/dashboard", params(("study" = i64, Path)),
    responses((status = 200, body = Dashboard)))]
pub(super) async fn admin_dashboard(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<Dashboard>> {
    let s = study::load(&state.db, id).await?;
    Ok(Json(dashboard::compute(&state.db, &s).await?.0))
}

/// The study's report for its kind: for a composition rating, the rate at which workers chose
/// the style-sorted composition with the one-sided t-test against 0.5 over workers.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/report", params(("study" = i64, Path)),
    responses((status = 200, body = crate::studies::report::StudyReport)))]
pub(super) async fn admin_report(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<crate::studies::report::StudyReport>> {
    let s = study::load(&state.db, id).await?;
    Ok(Json(crate::studies::report::report(&state.db, &s).await?))
}

/// Per-worker table.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/workers", params(("study" = i64, Path)),
    responses((status = 200, body = Vec<WorkerRow>)))]
pub(super) async fn admin_workers(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<Vec<WorkerRow>>> {
    let s = study::load(&state.db, id).await?;
    Ok(Json(dashboard::compute(&state.db, &s).await?.1))
}

/// Audit trail of decisions.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/audit", params(("study" = i64, Path)),
    responses((status = 200, body = Vec<DecisionRecord>)))]
pub(super) async fn admin_audit(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<Vec<DecisionRecord>>> {
    study::load(&state.db, id).await?;
    Ok(Json(qc::audit(&state.db, id).await?))
}

/// Which assignment a completion code belongs to.
#[derive(Debug, Serialize, ToSchema)]
pub struct CodeCheck {
    /// Whether the code is a valid completion code of this study.
    pub valid: bool,
    /// The assignment it belongs to.
    pub assignment: Option<AssignmentId>,
}

/// Longest completion code the check looks at (codes are far shorter).
const MAX_CODE: usize = 64;

/// Checks a completion code a worker submitted.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/codes/{code}",
    params(("study" = i64, Path), ("code" = String, Path, max_length = 64)),
    responses((status = 200, body = CodeCheck),
              (status = 400, description = "The code is longer than 64 characters", body = ErrorBody)))]
pub(super) async fn admin_verify_code(
    _admin: Admin,
    State(state): State<AppState>,
    ApiPath((id, code)): ApiPath<(StudyId, String)>,
) -> Result<Json<CodeCheck>> {
    if code.chars().count() > MAX_CODE {
        return Err(AppError::BadRequest(format!(
            "code: at most {MAX_CODE} characters"
        )));
    }
    let s = study::load(&state.db, id).await?;
    let assignment = flow::verify_code(&state.db, &s, &code).await?;
    Ok(Json(CodeCheck {
        valid: assignment.is_some(),
        assignment,
    }))
}

/// One export file.
#[utoipa::path(get, path = "/api/v1/admin/studies/{study}/export/{file}",
    params(("study" = i64, Path), ("file" = super::schema::ExportFile, Path), ExportOptions),
    responses((status = 200, description = "The file, as an attachment", content(
                  (String = "text/csv"), (String = "application/xml"),
                  (Object = "application/json"))),
              (status = 400, description = "A query parameter is not `true` or `false`, or a \
                  payment file was asked for in a pseudonymous export", body = ErrorBody),
              (status = 404, description = "No such study or export file", body = ErrorBody)))]
pub(super) async fn admin_export(
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
