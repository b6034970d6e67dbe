//! The admin login, logout, the list of studies and the creation of a study.

use askama::Template;
use axum::Router;
use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Redirect, Response};
use axum::routing::{get, post};
use serde::Deserialize;

use crate::AppState;
use crate::error::AppError;
use crate::store::ids::StudyId;
use crate::studies::library;
use crate::studies::study::{self, MAX_SLOTS, MAX_TUPLES, MturkMode, StudySettings, StudyStatus};
use crate::web::admin::{self, Admin};
use crate::web::extract::ApiForm;

/// Login, logout, the studies list and study creation.
pub(super) fn routes() -> Router<AppState> {
    Router::new()
        .route("/admin/login", get(login_page).post(login_submit))
        .route("/admin/logout", post(logout_submit))
        .route("/admin", get(admin_index))
        .route("/admin/studies", post(admin_create))
}
use super::{page, render};

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
    /// `creating` (with its percentage), `failed`, or empty when ready.
    state: String,
}

#[derive(Template)]
#[template(path = "admin_index.html")]
struct AdminIndex {
    username: String,
    csrf: String,
    studies: Vec<StudyRow>,
    libraries: Vec<String>,
    upload_limit: String,
    /// The creation form's bounds.
    max_tuples: u32,
    max_slots: u64,
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
                    state: match s.status {
                        StudyStatus::Ready => String::new(),
                        StudyStatus::Creating => {
                            format!("creating ({}%)", s.progress.percent())
                        }
                        StudyStatus::Failed => "failed".into(),
                    },
                })
                .collect();
            let libraries = crate::studies::library::library_names(&state.db).await?;
            render(&AdminIndex {
                username: admin.username,
                csrf: admin.csrf,
                studies,
                libraries,
                upload_limit: crate::studies::library::upload_limit_in_words(),
                max_tuples: MAX_TUPLES,
                max_slots: MAX_SLOTS,
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
            // A large pool goes on in the background; the study page shows its progress.
            let started =
                study::start_creation(&state.db, &f.name, library, settings, study::CREATE_WAIT)
                    .await?;
            Ok(Redirect::to(&format!("/admin/studies/{}", started.id)).into_response())
        }
        .await,
    )
}
