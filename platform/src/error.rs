//! The one error type of the platform. Handlers return `Result<_, AppError>`; the response shows
//! a short public message and logs the internal cause to stderr, never to the client.

use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use serde::Serialize;

/// What went wrong while serving a request (or running a CLI command).
#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// The request is malformed or a field is invalid; the message names the field.
    #[error("{0}")]
    BadRequest(String),
    /// No such study, assignment, item…
    #[error("{0} not found")]
    NotFound(&'static str),
    /// Not logged in (admin routes).
    #[error("login required")]
    Unauthorized,
    /// Logged in but the request is not allowed (missing CSRF token, worker not eligible…).
    #[error("{0}")]
    Forbidden(String),
    /// The request conflicts with stored state (e.g. a different answer to an answered question).
    #[error("{0}")]
    Conflict(String),
    /// The body has the wrong content type.
    #[error("{0}")]
    UnsupportedMediaType(String),
    /// Too many attempts (failed admin logins); retry later.
    #[error("{0}")]
    TooManyRequests(String),
    /// The upload or body is too large.
    #[error("{0}")]
    TooLarge(String),
    /// A database failure; details are logged, not shown.
    #[error("database error: {0}")]
    Database(#[from] sqlx::Error),
    /// A failure of the SQLite connection the answer writer drives directly
    /// ([`crate::store::sqlite_direct`]); details are logged, not shown.
    #[error("database error: {0}")]
    Sqlite(#[from] rusqlite::Error),
    /// A migration failure.
    #[error("migration error: {0}")]
    Migrate(#[from] sqlx::migrate::MigrateError),
    /// Writing to standard output failed (the command line; e.g. a closed pipe).
    #[error("cannot write to standard output: {0}")]
    Stdout(#[source] std::io::Error),
    /// Anything else internal; details are logged, not shown.
    #[error("internal error: {0}")]
    Internal(String),
}

/// `Result` with [`AppError`].
pub type Result<T, E = AppError> = std::result::Result<T, E>;

impl AppError {
    /// Wraps an internal failure (template, serialisation, image encoding…).
    pub fn internal(e: impl std::fmt::Display) -> Self {
        Self::Internal(e.to_string())
    }

    /// Another process held SQLite's write lock beyond the busy timeout: retrying may work.
    fn is_sqlite_busy(&self) -> bool {
        matches!(
            self,
            Self::Sqlite(rusqlite::Error::SqliteFailure(e, _))
                if e.code == rusqlite::ErrorCode::DatabaseBusy
        )
    }

    /// The HTTP status this error maps to.
    pub fn status(&self) -> StatusCode {
        match self {
            Self::BadRequest(_) => StatusCode::BAD_REQUEST,
            Self::NotFound(_) => StatusCode::NOT_FOUND,
            Self::Unauthorized => StatusCode::UNAUTHORIZED,
            Self::Forbidden(_) => StatusCode::FORBIDDEN,
            Self::Conflict(_) => StatusCode::CONFLICT,
            Self::TooLarge(_) => StatusCode::PAYLOAD_TOO_LARGE,
            Self::TooManyRequests(_) => StatusCode::TOO_MANY_REQUESTS,
            Self::UnsupportedMediaType(_) => StatusCode::UNSUPPORTED_MEDIA_TYPE,
            Self::Database(sqlx::Error::PoolTimedOut) => StatusCode::SERVICE_UNAVAILABLE,
            e if e.is_sqlite_busy() => StatusCode::SERVICE_UNAVAILABLE,
            Self::Database(_)
            | Self::Sqlite(_)
            | Self::Migrate(_)
            | Self::Internal(_)
            | Self::Stdout(_) => StatusCode::INTERNAL_SERVER_ERROR,
        }
    }

    /// The message a client may see.
    pub fn public_message(&self) -> String {
        match self {
            Self::Database(sqlx::Error::PoolTimedOut) => "server busy, retry".into(),
            e if e.is_sqlite_busy() => "server busy, retry".into(),
            Self::Database(_)
            | Self::Sqlite(_)
            | Self::Migrate(_)
            | Self::Internal(_)
            | Self::Stdout(_) => "internal error".into(),
            other => other.to_string(),
        }
    }
}

/// The JSON body of every error response.
#[derive(Debug, Serialize, utoipa::ToSchema)]
pub struct ErrorBody {
    /// Human-readable message.
    pub error: String,
}

/// The public message of an error response made from an [`AppError`], in the response's
/// extensions: outside `/api/` the server shows it as an HTML page instead of the JSON body
/// (a rejected path or form of a page, an unknown URL), see [`crate::app`].
#[derive(Debug, Clone)]
pub struct PublicError(pub String);

impl IntoResponse for AppError {
    fn into_response(self) -> Response {
        let status = self.status();
        if status.is_server_error() {
            eprintln!("error: {self}");
        }
        let message = self.public_message();
        let mut response = (
            status,
            axum::Json(ErrorBody {
                error: message.clone(),
            }),
        )
            .into_response();
        response.extensions_mut().insert(PublicError(message));
        response
    }
}
