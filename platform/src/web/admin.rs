//! Admin accounts and sessions: argon2id password hashes, a random session token in an
//! `HttpOnly; SameSite=Strict` cookie (only its SHA-256 is stored), and a per-session CSRF token
//! that every state-changing admin request must echo (form field `csrf` or header
//! `x-csrf-token`).

use argon2::Argon2;
use argon2::password_hash::{PasswordHash, PasswordHasher, PasswordVerifier, SaltString};
use axum::extract::FromRequestParts;
use axum::http::request::Parts;
use sha2::{Digest, Sha256};
use sqlx::Row;

use crate::AppState;
use crate::error::{AppError, Result};
use crate::store::db::{Db, now_ms};
use crate::store::ids::{AdminId, random_token};

/// Name of the session cookie.
pub const COOKIE: &str = "platform_session";
/// Session lifetime.
pub const SESSION_MS: i64 = 12 * 3600 * 1000;

fn hash_token(token: &str) -> String {
    hex::encode(Sha256::digest(token.as_bytes()))
}

/// Creates an admin (or resets the password of an existing one).
pub async fn create_admin(db: &Db, username: &str, password: &str) -> Result<AdminId> {
    if username.is_empty()
        || username.len() > 64
        || !username
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
    {
        return Err(AppError::BadRequest(
            "username: 1-64 letters, digits, -_.".into(),
        ));
    }
    if password.len() < 12 {
        return Err(AppError::BadRequest(
            "password: at least 12 characters".into(),
        ));
    }
    let password = password.to_string();
    let hash = tokio::task::spawn_blocking(move || {
        let mut salt_bytes = [0u8; 16];
        rand::RngCore::fill_bytes(&mut rand::rng(), &mut salt_bytes);
        let salt = SaltString::encode_b64(&salt_bytes).map_err(AppError::internal)?;
        Argon2::default()
            .hash_password(password.as_bytes(), &salt)
            .map(|h| h.to_string())
            .map_err(AppError::internal)
    })
    .await
    .map_err(AppError::internal)??;
    let id = AdminId::generate();
    sqlx::query(
        "INSERT INTO admins (id, username, password_hash, created_at) VALUES ($1, $2, $3, $4) \
         ON CONFLICT (username) DO UPDATE SET password_hash = excluded.password_hash",
    )
    .bind(id.0)
    .bind(username)
    .bind(hash)
    .bind(now_ms())
    .execute(&mut *db.write_conn().await?)
    .await?;
    let row = sqlx::query("SELECT id FROM admins WHERE username = $1")
        .bind(username)
        .fetch_one(&db.pool)
        .await?;
    // A new password lifts a login lock-out.
    clear_failures(db, username).await?;
    Ok(AdminId(row.try_get("id")?))
}

/// Failed logins of one username within [`LOGIN_WINDOW_MS`] after which further attempts are
/// refused until the window has passed (password guessing gets ~40 tries an hour).
pub const MAX_LOGIN_FAILURES: i64 = 10;

/// The throttling window.
pub const LOGIN_WINDOW_MS: i64 = 15 * 60 * 1000;

/// Refuses a login when the username has [`MAX_LOGIN_FAILURES`] recent failures. Counted per
/// username, in the database (not per client address, which a load balancer hides); the
/// price is that someone can hold an account's login shut for the window, which
/// `platform admin create` (a password reset) lifts.
async fn check_throttle(db: &Db, username: &str) -> Result<()> {
    let row = sqlx::query(
        "SELECT COUNT(*) AS n, MIN(at) AS first FROM login_failures WHERE username = $1 AND at > $2",
    )
    .bind(username)
    .bind(now_ms() - LOGIN_WINDOW_MS)
    .fetch_one(&db.pool)
    .await?;
    let failures: i64 = row.try_get("n")?;
    if failures >= MAX_LOGIN_FAILURES {
        let first: Option<i64> = row.try_get("first")?;
        let wait_ms = first.map_or(LOGIN_WINDOW_MS, |f| f + LOGIN_WINDOW_MS - now_ms());
        return Err(AppError::TooManyRequests(format!(
            "too many failed logins for this account; try again in {} minute(s)",
            (wait_ms.max(0) + 59_999) / 60_000
        )));
    }
    Ok(())
}

async fn record_failure(db: &Db, username: &str) -> Result<()> {
    sqlx::query("DELETE FROM login_failures WHERE at < $1")
        .bind(now_ms() - LOGIN_WINDOW_MS)
        .execute(&mut *db.write_conn().await?)
        .await?;
    sqlx::query("INSERT INTO login_failures (username, at) VALUES ($1, $2)")
        .bind(username)
        .bind(now_ms())
        .execute(&mut *db.write_conn().await?)
        .await?;
    Ok(())
}

async fn clear_failures(db: &Db, username: &str) -> Result<()> {
    sqlx::query("DELETE FROM login_failures WHERE username = $1")
        .bind(username)
        .execute(&mut *db.write_conn().await?)
        .await?;
    Ok(())
}

/// Checks credentials; on success creates a session and returns (cookie token, CSRF token).
/// Refused with [`AppError::TooManyRequests`] after [`MAX_LOGIN_FAILURES`] recent failures.
pub async fn login(db: &Db, username: &str, password: &str) -> Result<Option<(String, String)>> {
    if username.len() > 64 || password.len() > 1024 {
        return Ok(None);
    }
    check_throttle(db, username).await?;
    let row = sqlx::query("SELECT id, password_hash FROM admins WHERE username = $1")
        .bind(username)
        .fetch_optional(&db.pool)
        .await?;
    // Verify against a dummy hash when the user does not exist, so timing does not tell.
    let (id, stored): (Option<i64>, String) = match row {
        Some(r) => (Some(r.try_get("id")?), r.try_get("password_hash")?),
        None => (
            None,
            "$argon2id$v=19$m=19456,t=2,p=1$c29tZXNhbHRzb21lc2FsdA$R5N3S2Ik8N5PpRZ3PVgS5QZr7Nd4X8h3J4B6kqS7p2c".into(),
        ),
    };
    let password = password.to_string();
    let ok = tokio::task::spawn_blocking(move || {
        PasswordHash::new(&stored)
            .map(|h| {
                Argon2::default()
                    .verify_password(password.as_bytes(), &h)
                    .is_ok()
            })
            .unwrap_or(false)
    })
    .await
    .map_err(AppError::internal)?;
    let Some(id) = id.filter(|_| ok) else {
        record_failure(db, username).await?;
        return Ok(None);
    };
    clear_failures(db, username).await?;
    let token = random_token();
    let csrf = random_token();
    sqlx::query("DELETE FROM sessions WHERE expires_at < $1")
        .bind(now_ms())
        .execute(&mut *db.write_conn().await?)
        .await?;
    sqlx::query(
        "INSERT INTO sessions (token_hash, admin_id, csrf, expires_at) VALUES ($1, $2, $3, $4)",
    )
    .bind(hash_token(&token))
    .bind(id)
    .bind(&csrf)
    .bind(now_ms() + SESSION_MS)
    .execute(&mut *db.write_conn().await?)
    .await?;
    Ok(Some((token, csrf)))
}

/// Ends a session.
pub async fn logout(db: &Db, token: &str) -> Result<()> {
    sqlx::query("DELETE FROM sessions WHERE token_hash = $1")
        .bind(hash_token(token))
        .execute(&mut *db.write_conn().await?)
        .await?;
    Ok(())
}

/// The `Set-Cookie` value for a session token (`Secure` when configured).
pub fn session_cookie(token: &str, secure: bool) -> String {
    format!(
        "{COOKIE}={token}; HttpOnly; SameSite=Strict; Path=/; Max-Age={}{}",
        SESSION_MS / 1000,
        if secure { "; Secure" } else { "" }
    )
}

/// A logged-in admin (extractor: rejects anonymous requests with 401).
#[derive(Debug, Clone)]
pub struct Admin {
    /// Account id.
    pub id: AdminId,
    /// Username.
    pub username: String,
    /// This session's CSRF token.
    pub csrf: String,
    /// The session cookie value.
    pub token: String,
}

impl Admin {
    /// Checks a CSRF token from a form or header.
    pub fn check_csrf(&self, given: Option<&str>) -> Result<()> {
        let given = given.unwrap_or_default();
        // Constant-time compare.
        let same = given.len() == self.csrf.len()
            && given
                .bytes()
                .zip(self.csrf.bytes())
                .fold(0u8, |acc, (x, y)| acc | (x ^ y))
                == 0;
        if same {
            Ok(())
        } else {
            Err(AppError::Forbidden("missing or wrong CSRF token".into()))
        }
    }
}

/// The session token from the `Cookie` header, if any.
pub fn cookie_token(parts: &Parts) -> Option<String> {
    parts
        .headers
        .get_all(axum::http::header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .filter_map(|kv| kv.trim().split_once('='))
        .find(|(k, _)| *k == COOKIE)
        .map(|(_, v)| v.to_string())
}

impl FromRequestParts<AppState> for Admin {
    type Rejection = AppError;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self> {
        let token = cookie_token(parts).ok_or(AppError::Unauthorized)?;
        if token.len() != 32 {
            return Err(AppError::Unauthorized);
        }
        let row = sqlx::query(
            "SELECT s.admin_id, s.csrf, a.username FROM sessions s JOIN admins a ON a.id = s.admin_id \
             WHERE s.token_hash = $1 AND s.expires_at > $2",
        )
        .bind(hash_token(&token))
        .bind(now_ms())
        .fetch_optional(&state.db.pool)
        .await?
        .ok_or(AppError::Unauthorized)?;
        let admin = Admin {
            id: AdminId(row.try_get("admin_id")?),
            username: row.try_get("username")?,
            csrf: row.try_get("csrf")?,
            token,
        };
        // State-changing JSON requests carry the CSRF token in a header; HTML forms are checked
        // by their handlers (the token is a form field).
        let unsafe_method = !matches!(parts.method.as_str(), "GET" | "HEAD" | "OPTIONS");
        if unsafe_method && parts.uri.path().starts_with("/api/") {
            let header = parts
                .headers
                .get("x-csrf-token")
                .and_then(|v| v.to_str().ok());
            admin.check_csrf(header)?;
        }
        Ok(admin)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cookie_is_httponly_and_samesite() {
        let c = session_cookie("abc", false);
        assert!(c.contains("HttpOnly") && c.contains("SameSite=Strict") && !c.contains("Secure"));
        assert!(session_cookie("abc", true).ends_with("; Secure"));
    }
}
