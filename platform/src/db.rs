//! The database layer: one sqlx `Any` pool over SQLite or PostgreSQL, one migration set, `$n`
//! bound parameters everywhere (never string-built SQL).
//!
//! SQLite runs in WAL mode with `synchronous=FULL`, so an acknowledged answer survives a crash;
//! write transactions start with `BEGIN IMMEDIATE` there so two writers never deadlock on a
//! lock upgrade. PostgreSQL uses its default READ COMMITTED isolation: every claim is a
//! conditional `UPDATE ... WHERE assignment_id IS NULL`, which PostgreSQL re-checks after waiting
//! for a concurrent writer, so a slot is never filled twice.

use std::time::{Duration, SystemTime, UNIX_EPOCH};

use sqlx::any::{AnyPoolOptions, AnyRow};
use sqlx::{Any, AnyPool, Executor, Transaction};

use crate::answer_writer::AnswerWriter;
use crate::error::{AppError, Result};

/// Which database the pool talks to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backend {
    /// An embedded SQLite file.
    Sqlite,
    /// A PostgreSQL server.
    Postgres,
}

/// A pool plus the facts about its backend.
#[derive(Debug, Clone)]
pub struct Db {
    /// The connection pool for reads (and, on PostgreSQL, everything).
    pub pool: AnyPool,
    /// The pool for writes. On SQLite it has one connection, so writers queue in the pool
    /// (FIFO, without SQLite's sleeping busy handler) while readers proceed in parallel (WAL);
    /// on PostgreSQL it is the same pool as `pool`. A performance measure only: correctness
    /// rests on the transactions, not on this queue.
    pub writer: AnyPool,
    /// The backend behind it.
    pub backend: Backend,
    /// Group commit of answers through `writer` (see [`crate::answer_writer`]).
    pub answers: AnswerWriter,
}

/// Migrations embedded at build time.
pub static MIGRATOR: sqlx::migrate::Migrator = sqlx::migrate!("./migrations");

/// Milliseconds since the Unix epoch.
pub fn now_ms() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_millis() as i64)
        .unwrap_or(0)
}

impl Db {
    /// Connects to `url` (`sqlite://PATH` — created if missing — or `postgres://…`) and runs the
    /// migrations.
    pub async fn connect(url: &str, max_connections: u32) -> Result<Self> {
        sqlx::any::install_default_drivers();
        let backend = if url.starts_with("sqlite:") {
            Backend::Sqlite
        } else if url.starts_with("postgres:") || url.starts_with("postgresql:") {
            Backend::Postgres
        } else {
            return Err(AppError::BadRequest(format!(
                "unsupported database URL (expected sqlite://PATH or postgres://…): {}",
                redact(url)
            )));
        };
        let url = match backend {
            Backend::Sqlite if !url.contains('?') => format!("{url}?mode=rwc"),
            _ => url.to_string(),
        };
        let options = |max: u32| {
            let options = AnyPoolOptions::new()
                .max_connections(max)
                .acquire_timeout(Duration::from_secs(30));
            if backend == Backend::Sqlite {
                options.after_connect(|conn, _meta| {
                    Box::pin(async move {
                        conn.execute("PRAGMA journal_mode=WAL").await?;
                        conn.execute("PRAGMA synchronous=FULL").await?;
                        conn.execute("PRAGMA foreign_keys=ON").await?;
                        conn.execute("PRAGMA busy_timeout=10000").await?;
                        Ok(())
                    })
                })
            } else {
                options
            }
        };
        let pool = options(max_connections).connect(&url).await?;
        MIGRATOR.run(&pool).await?;
        let writer = match backend {
            Backend::Sqlite => options(1).connect(&url).await?,
            Backend::Postgres => pool.clone(),
        };
        let answers = AnswerWriter::start(writer.clone(), backend);
        Ok(Self {
            pool,
            writer,
            backend,
            answers,
        })
    }

    /// Begins a write transaction (`BEGIN IMMEDIATE` on SQLite).
    pub async fn begin_write(&self) -> Result<Transaction<'static, Any>> {
        Ok(match self.backend {
            Backend::Sqlite => self.writer.begin_with("BEGIN IMMEDIATE").await?,
            Backend::Postgres => self.writer.begin().await?,
        })
    }

    /// `SELECT 1`: is the database reachable?
    pub async fn ping(&self) -> Result<()> {
        sqlx::query("SELECT 1").execute(&self.pool).await?;
        Ok(())
    }
}

/// The URL without its password, for messages.
pub fn redact(url: &str) -> String {
    match (url.find("://"), url.rfind('@')) {
        (Some(scheme), Some(at)) if at > scheme => {
            let userinfo = &url[scheme + 3..at];
            let user = userinfo.split(':').next().unwrap_or("");
            format!("{}://{}:***@{}", &url[..scheme], user, &url[at + 1..])
        }
        _ => url.to_string(),
    }
}

/// Reads column `col` of `row`, mapping a missing/mistyped column to an internal error.
pub fn get<'r, T>(row: &'r AnyRow, col: &str) -> Result<T>
where
    T: sqlx::Decode<'r, Any> + sqlx::Type<Any>,
{
    use sqlx::Row;
    row.try_get(col).map_err(AppError::from)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn redacts_passwords() {
        assert_eq!(
            redact("postgres://app:secret@127.0.0.1:5432/app"),
            "postgres://app:***@127.0.0.1:5432/app"
        );
        assert_eq!(redact("sqlite://x.db"), "sqlite://x.db");
    }
}
