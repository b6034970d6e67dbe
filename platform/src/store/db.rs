//! The database layer: one sqlx `Any` pool over SQLite or PostgreSQL, one migration set, `$n`
//! bound parameters everywhere (never string-built SQL).
//!
//! SQLite runs in WAL mode with `synchronous=FULL`, so an acknowledged write survives a crash
//! (the answer writer's own connection uses `NORMAL` and fdatasyncs the WAL itself before it
//! answers anyone, see [`crate::store::answer_writer`]); write transactions start with `BEGIN
//! IMMEDIATE` there so two writers never deadlock on a lock upgrade. PostgreSQL uses its
//! default READ COMMITTED isolation: every claim is a conditional `UPDATE ... WHERE
//! assignment_id IS NULL`, which PostgreSQL re-checks after waiting for a concurrent writer, so
//! a slot is never filled twice.

use std::ops::{Deref, DerefMut};
use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use sqlx::any::{AnyPoolOptions, AnyRow};
use sqlx::pool::PoolConnection;
use sqlx::{Any, AnyConnection, AnyPool, Executor, Transaction};
use tokio::sync::{Mutex, OwnedMutexGuard};

use crate::error::{AppError, Result};
use crate::store::answer_writer::AnswerWriter;

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
    /// The pool for writes through sqlx ([`Db::begin_write`], [`Db::write_conn`]). On SQLite
    /// it has one connection, used under the process's write turn, which the answer writer's
    /// own connection takes too, so writers queue (FIFO, without SQLite's sleeping busy
    /// handler) while readers proceed in parallel (WAL); on PostgreSQL it is the same pool as
    /// `pool`. A performance measure only: correctness rests on the transactions.
    pub writer: AnyPool,
    /// The backend behind it.
    pub backend: Backend,
    /// Group commit of answers (see [`crate::store::answer_writer`]): on SQLite through a connection
    /// of its own, on PostgreSQL through `pool`.
    pub answers: AnswerWriter,
    /// SQLite only: the process's write turn, taken by the answer writer for each batch and
    /// by every sqlx write (see [`Db::begin_write`]).
    turns: Option<Arc<Mutex<()>>>,
}

/// A write transaction from [`Db::begin_write`]. Use it like the transaction's connection
/// (`&mut *tx`); it ends with [`WriteTx::commit`], or rolls back when dropped.
pub struct WriteTx {
    tx: Transaction<'static, Any>,
    /// This process's turn at SQLite's writer, released after the transaction (fields drop in
    /// order: the transaction first).
    _turn: Option<OwnedMutexGuard<()>>,
}

impl WriteTx {
    /// Commits.
    pub async fn commit(self) -> Result<()> {
        Ok(self.tx.commit().await?)
    }

    /// Rolls back.
    pub async fn rollback(self) -> Result<()> {
        Ok(self.tx.rollback().await?)
    }
}

impl Deref for WriteTx {
    type Target = AnyConnection;
    fn deref(&self) -> &AnyConnection {
        &self.tx
    }
}

impl DerefMut for WriteTx {
    fn deref_mut(&mut self) -> &mut AnyConnection {
        &mut self.tx
    }
}

/// The writer connection from [`Db::write_conn`]; use it as `&mut *conn`.
pub struct WriteConn {
    conn: PoolConnection<Any>,
    /// This process's turn at SQLite's writer, released after the connection is back in the
    /// pool (fields drop in order).
    _turn: Option<OwnedMutexGuard<()>>,
}

impl Deref for WriteConn {
    type Target = AnyConnection;
    fn deref(&self) -> &AnyConnection {
        &self.conn
    }
}

impl DerefMut for WriteConn {
    fn deref_mut(&mut self) -> &mut AnyConnection {
        &mut self.conn
    }
}

/// The database file of a `sqlite:` URL, as SQLite would open it (the answer writer opens its
/// own connection to it).
fn sqlite_file(url: &str) -> Result<std::path::PathBuf> {
    use std::str::FromStr;
    let options = sqlx::sqlite::SqliteConnectOptions::from_str(url)?;
    Ok(options.get_filename().to_path_buf())
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
                .acquire_timeout(Duration::from_secs(30))
                // sqlx pings every connection before handing it out. For a network database
                // that catches a dropped link; a SQLite connection is a file handle that cannot
                // go stale, and the ping is one more round trip to the connection's thread on
                // every request (/healthz: +20% throughput without it).
                .test_before_acquire(backend == Backend::Postgres);
            if backend == Backend::Sqlite {
                options.after_connect(|conn, _meta| {
                    Box::pin(async move {
                        conn.execute("PRAGMA journal_mode=WAL").await?;
                        conn.execute("PRAGMA synchronous=FULL").await?;
                        conn.execute("PRAGMA foreign_keys=ON").await?;
                        conn.execute("PRAGMA busy_timeout=10000").await?;
                        // Statement and savepoint journals (the answer writer runs each job
                        // in a savepoint) in memory instead of a temporary file: they only
                        // serve rollbacks within a transaction, never durability.
                        conn.execute("PRAGMA temp_store=MEMORY").await?;
                        Ok(())
                    })
                })
            } else {
                options
            }
        };
        let pool = options(max_connections).connect(&url).await?;
        MIGRATOR.run(&pool).await?;
        let (writer, answers, turns) = match backend {
            Backend::Sqlite => {
                let turns = Arc::new(Mutex::new(()));
                let file = sqlite_file(&url)?;
                let answers = AnswerWriter::start_sqlite(&file, turns.clone())?;
                (options(1).connect(&url).await?, answers, Some(turns))
            }
            Backend::Postgres => (
                pool.clone(),
                AnswerWriter::start_postgres(pool.clone())?,
                None,
            ),
        };
        Ok(Self {
            pool,
            writer,
            backend,
            answers,
            turns,
        })
    }

    /// Begins a write transaction (`BEGIN IMMEDIATE` on SQLite).
    ///
    /// On SQLite these transactions (training submissions, admin writes; answers, HIT
    /// allocations and completions go through the answer writer instead, see
    /// [`crate::store::answer_writer`]) first take the process's write turn, which the answer writer
    /// takes for each of its batches too. The turn serves waiters in order, so the answer
    /// writer's batches alternate with the other writes one by one, and nobody sleeps in
    /// SQLite's busy handler (which polls at growing intervals and may lose to a writer that
    /// comes back at once). A latency measure only: SQLite's own lock still serialises every
    /// writer, across processes too.
    pub async fn begin_write(&self) -> Result<WriteTx> {
        let turn = self.turn().await;
        let tx = match self.backend {
            Backend::Sqlite => self.writer.begin_with("BEGIN IMMEDIATE").await?,
            Backend::Postgres => self.writer.begin().await?,
        };
        Ok(WriteTx { tx, _turn: turn })
    }

    /// The writer connection for single-statement writes outside a transaction, under the
    /// write turn (see [`Db::begin_write`]) until it is dropped.
    pub async fn write_conn(&self) -> Result<WriteConn> {
        let turn = self.turn().await;
        let conn = self.writer.acquire().await?;
        Ok(WriteConn { conn, _turn: turn })
    }

    /// SQLite: the process's write turn, in arrival order; PostgreSQL: none.
    async fn turn(&self) -> Option<OwnedMutexGuard<()>> {
        match &self.turns {
            Some(turns) => Some(turns.clone().lock_owned().await),
            None => None,
        }
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
