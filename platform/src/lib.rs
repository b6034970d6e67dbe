//! The rating-study platform of Garces et al. 2014 (§5.4) and 2016 (§6.3.2): triplet studies
//! ("Is A more similar in style to B or to C?") for MTurk, Prolific and direct links, with a
//! training gate, hidden control questions, quality control with an audit trail, an admin
//! dashboard and exports in the learner's triplet format.
//!
//! The server is [`app`] over an [`AppState`]; all state lives in the database (SQLite or
//! PostgreSQL, one migration set), so several servers can share one PostgreSQL.
//!
//! ```no_run
//! # async fn demo() -> Result<(), platform::error::AppError> {
//! let db = platform::store::db::Db::connect("sqlite://study.db", 8).await?;
//! let state = platform::AppState::new(db, "http://127.0.0.1:8080".into(), false, 65536);
//! let listener = tokio::net::TcpListener::bind("127.0.0.1:8080").await.map_err(platform::error::AppError::internal)?;
//! axum::serve(listener, platform::app(state)).await.map_err(platform::error::AppError::internal)?;
//! # Ok(()) }
//! ```

use std::sync::Arc;

use axum::Router;
use axum::extract::DefaultBodyLimit;
use axum::http::{HeaderValue, StatusCode, header};
use axum::response::Response;
use tower_http::set_header::SetResponseHeaderLayer;

/// `println!` that returns [`error::AppError::Stdout`] instead of panicking when standard
/// output is closed (`platform study status 1 | head -c 10`); `main` ends quietly on that.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*).map_err($crate::error::AppError::Stdout)
    }};
}

pub mod cli;
pub mod error;
pub mod explore;
pub mod flow;
pub mod mashup;
pub mod search;
pub mod store;
pub mod studies;
pub mod time;
pub mod web;

use studies::library;
use web::{api, assets, pages};

/// Server-wide settings that are not in the database.
#[derive(Debug, Clone)]
pub struct ServerSettings {
    /// The address workers and MTurk reach this server at (links, ExternalQuestion).
    pub public_url: String,
    /// Mark the session cookie `Secure` (behind HTTPS).
    pub secure_cookies: bool,
    /// Largest accepted request body (uploads have their own limit).
    pub max_body_bytes: usize,
}

/// What every handler gets.
#[derive(Debug, Clone)]
pub struct AppState {
    /// The database.
    pub db: store::db::Db,
    /// Settings.
    pub settings: Arc<ServerSettings>,
    /// Built style-search indexes (a cache; rebuilt from the database when missing).
    pub search: Arc<search::IndexCache>,
    /// Finished style maps this server has parsed (a cache; maps never change once done).
    pub explore_maps: Arc<explore::map::MapCache>,
}

impl AppState {
    /// Bundles a database and settings.
    pub fn new(
        db: store::db::Db,
        public_url: String,
        secure_cookies: bool,
        max_body_bytes: usize,
    ) -> Self {
        Self {
            db,
            settings: Arc::new(ServerSettings {
                public_url,
                secure_cookies,
                max_body_bytes,
            }),
            search: Arc::default(),
            explore_maps: Arc::default(),
        }
    }
}

/// Largest multipart upload: [`library::MAX_UPLOAD_FILES`] files of at most
/// [`library::MAX_UPLOAD_BYTES`], plus room for the form's other fields and part headers.
pub const MAX_UPLOAD_REQUEST: usize =
    library::MAX_UPLOAD_FILES * library::MAX_UPLOAD_BYTES + 256 * 1024;

/// The whole application: JSON API, worker pages, admin pages.
pub fn app(state: AppState) -> Router {
    let limit = state.settings.max_body_bytes;
    let upload = Router::new()
        .route(
            "/admin/library/upload",
            axum::routing::post(pages::upload_handler),
        )
        .layer(DefaultBodyLimit::max(MAX_UPLOAD_REQUEST));
    let example = api::example_routes()
        .merge(pages::example_routes())
        .layer(DefaultBodyLimit::max(search::example::MAX_EXAMPLE_REQUEST));
    Router::new()
        .merge(api::routes())
        .merge(pages::routes())
        .layer(DefaultBodyLimit::max(limit))
        .merge(upload)
        .merge(example)
        .merge(api::compositions::routes())
        .route("/favicon.ico", axum::routing::get(assets::favicon))
        .fallback(|| async { error::AppError::NotFound("page") })
        .layer(axum::middleware::from_fn(html_errors))
        .layer(axum::middleware::from_fn(assets::csp))
        .layer(SetResponseHeaderLayer::overriding(
            header::REFERRER_POLICY,
            HeaderValue::from_static("no-referrer"),
        ))
        .layer(SetResponseHeaderLayer::overriding(
            header::X_CONTENT_TYPE_OPTIONS,
            HeaderValue::from_static("nosniff"),
        ))
        .with_state(state)
}

/// Middleware: an error response made from an [`error::AppError`] outside `/api/` (and
/// `/healthz`) becomes an HTML page with the same status, for browsers: an unknown URL, or a
/// page's path or form its extractor rejected before the handler could render the error.
/// The JSON API keeps its JSON errors.
async fn html_errors(req: axum::extract::Request, next: axum::middleware::Next) -> Response {
    let json = req.uri().path().starts_with("/api/") || req.uri().path() == "/healthz";
    let response = next.run(req).await;
    if json {
        return response;
    }
    match response.extensions().get::<error::PublicError>() {
        Some(error::PublicError(message)) => pages::status_page(response.status(), message.clone()),
        // axum's own empty 405 (a GET of a form's address, say); the Allow header stays.
        None if response.status() == StatusCode::METHOD_NOT_ALLOWED => {
            let allow = response.headers().get(header::ALLOW).cloned();
            let mut page = pages::status_page(
                StatusCode::METHOD_NOT_ALLOWED,
                "this address is not a page: it takes a form".into(),
            );
            if let Some(allow) = allow {
                page.headers_mut().insert(header::ALLOW, allow);
            }
            page
        }
        None => response,
    }
}

/// Serves `app` on `listener` until Ctrl-C / SIGTERM. Meanwhile, and first at start, studies
/// whose creation stopped (the process writing their pool died) are marked failed and their
/// rows deleted ([`study::watch`]).
pub async fn serve(listener: tokio::net::TcpListener, state: AppState) -> std::io::Result<()> {
    let watch = studies::study::watch(state.db.clone());
    let served = serve_app(listener, state).await;
    watch.abort();
    served
}

async fn serve_app(listener: tokio::net::TcpListener, state: AppState) -> std::io::Result<()> {
    axum::serve(listener, app(state))
        .with_graceful_shutdown(async {
            let ctrl_c = tokio::signal::ctrl_c();
            #[cfg(unix)]
            {
                let mut term =
                    match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
                    {
                        Ok(t) => t,
                        Err(_) => {
                            let _ = ctrl_c.await;
                            return;
                        }
                    };
                tokio::select! {
                    _ = ctrl_c => {},
                    _ = term.recv() => {},
                }
            }
            #[cfg(not(unix))]
            {
                let _ = ctrl_c.await;
            }
        })
        .await
}
