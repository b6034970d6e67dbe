//! A SQLite connection driven directly (rusqlite, over the same linked SQLite as sqlx), for the
//! one thread that writes answers ([`crate::store::answer_writer`]).
//!
//! Why not sqlx there: sqlx runs every SQLite connection on a thread of its own and hands each
//! statement and each result to it through a channel, so the single writer, which every answer
//! waits for, spent its time on thread hand-offs between short statements. Driven directly, a
//! statement is a function call, so the batch can use one small prepared statement per answer
//! (an indexed `UPDATE` costs ~6 µs there, against ~15 µs per answer for the `UPDATE … FROM
//! json_each(…)` that batching through sqlx needed; measured with SQLite 3.40 on the benchmark's
//! database).
//!
//! The SQL keeps sqlx's `$1, $2…` parameters, so a statement text can be shared with the sqlx
//! code of the same write on PostgreSQL: for SQLite they are named parameters, bound here by
//! name.

use std::path::Path;
use std::time::Duration;

use rusqlite::types::ToSql;
use rusqlite::{CachedStatement, Connection, OpenFlags, Row};

use crate::error::{AppError, Result};

/// Opens the database file with the pragmas of the sqlx pool ([`crate::store::db::Db::connect`]): WAL,
/// `synchronous=FULL` (an acknowledged answer survives a crash), foreign keys, a busy timeout
/// for other processes' writers, and in-memory statement journals.
pub fn open(path: &Path) -> Result<Connection> {
    let conn = Connection::open_with_flags(
        path,
        OpenFlags::SQLITE_OPEN_READ_WRITE | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )?;
    conn.busy_timeout(Duration::from_secs(10))?;
    conn.execute_batch(
        "PRAGMA journal_mode=WAL; PRAGMA synchronous=FULL; PRAGMA foreign_keys=ON; \
         PRAGMA temp_store=MEMORY;",
    )?;
    conn.set_prepared_statement_cache_capacity(64);
    Ok(conn)
}

/// `$n`, without an allocation for the first 32 (binding runs for every parameter of every
/// statement of the answer writer).
fn parameter_name(n: usize) -> std::borrow::Cow<'static, str> {
    const NAMES: [&str; 32] = [
        "$0", "$1", "$2", "$3", "$4", "$5", "$6", "$7", "$8", "$9", "$10", "$11", "$12", "$13",
        "$14", "$15", "$16", "$17", "$18", "$19", "$20", "$21", "$22", "$23", "$24", "$25", "$26",
        "$27", "$28", "$29", "$30", "$31",
    ];
    match NAMES.get(n) {
        Some(name) => (*name).into(),
        None => format!("${n}").into(),
    }
}

/// `sql` prepared (from the connection's cache) with `params` bound to `$1, $2…`.
fn bound<'c>(
    conn: &'c Connection,
    sql: &str,
    params: &[&dyn ToSql],
) -> Result<CachedStatement<'c>> {
    let mut stmt = conn.prepare_cached(sql)?;
    for (i, value) in params.iter().enumerate() {
        let name = parameter_name(i + 1);
        let index = stmt.parameter_index(&name)?.ok_or_else(|| {
            AppError::Internal(format!("statement has no parameter {name}: {sql}"))
        })?;
        stmt.raw_bind_parameter(index, *value)?;
    }
    if stmt.parameter_count() != params.len() {
        return Err(AppError::Internal(format!(
            "statement takes {} parameters, {} bound: {sql}",
            stmt.parameter_count(),
            params.len()
        )));
    }
    Ok(stmt)
}

/// Runs a statement; returns the number of rows it changed.
pub fn execute(conn: &Connection, sql: &str, params: &[&dyn ToSql]) -> Result<usize> {
    Ok(bound(conn, sql, params)?.raw_execute()?)
}

/// The first row of a query mapped by `f`, `None` without rows.
pub fn optional_row<T>(
    conn: &Connection,
    sql: &str,
    params: &[&dyn ToSql],
    f: impl FnOnce(&Row<'_>) -> rusqlite::Result<T>,
) -> Result<Option<T>> {
    let mut stmt = bound(conn, sql, params)?;
    let mut rows = stmt.raw_query();
    match rows.next()? {
        Some(row) => Ok(Some(f(row)?)),
        None => Ok(None),
    }
}

/// Every row of a query mapped by `f`.
pub fn rows<T>(
    conn: &Connection,
    sql: &str,
    params: &[&dyn ToSql],
    mut f: impl FnMut(&Row<'_>) -> rusqlite::Result<T>,
) -> Result<Vec<T>> {
    let mut stmt = bound(conn, sql, params)?;
    let mut rows = stmt.raw_query();
    let mut out = Vec::new();
    while let Some(row) = rows.next()? {
        out.push(f(row)?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `$n` parameters are bound by name whatever their order in the text, a repeated one
    /// takes one value, and a wrong count is an error rather than a silent NULL.
    #[test]
    fn binds_dollar_parameters_by_name() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("t.db");
        Connection::open(&path).expect("create");
        let conn = open(&path).expect("open");
        execute(&conn, "CREATE TABLE t (a INTEGER, b TEXT)", &[]).expect("create");
        let n = execute(
            &conn,
            "INSERT INTO t (b, a) VALUES ($2, $1), ($2 || '!', $1 + 1)",
            &[&7_i64, &"x"],
        )
        .expect("insert");
        assert_eq!(n, 2);
        let got = rows(&conn, "SELECT a, b FROM t ORDER BY a", &[], |r| {
            Ok((r.get::<_, i64>(0)?, r.get::<_, String>(1)?))
        })
        .expect("rows");
        assert_eq!(got, vec![(7, "x".to_string()), (8, "x!".to_string())]);
        let none = optional_row(&conn, "SELECT a FROM t WHERE a = $1", &[&99_i64], |r| {
            r.get::<_, i64>(0)
        })
        .expect("query");
        assert_eq!(none, None);
        assert!(execute(&conn, "UPDATE t SET a = $1 WHERE b = $2", &[&1_i64]).is_err());
        assert!(execute(&conn, "UPDATE t SET a = $1", &[&1_i64, &2_i64]).is_err());
        let mode: String = conn
            .query_row("PRAGMA journal_mode", [], |r| r.get(0))
            .expect("pragma");
        assert_eq!(mode, "wal");
        // Past the table of preset names: `$32` and beyond are formatted, and bound all the same.
        let sql = format!(
            "SELECT {}",
            (1..=40)
                .map(|n| format!("${n}"))
                .collect::<Vec<_>>()
                .join(" + ")
        );
        let ones = [1_i64; 40];
        let params: Vec<&dyn ToSql> = ones.iter().map(|v| v as &dyn ToSql).collect();
        let sum = optional_row(&conn, &sql, &params, |r| r.get::<_, i64>(0)).expect("40 params");
        assert_eq!(sum, Some(40));
    }
}
