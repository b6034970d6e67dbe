//! The stored condition of each assignment of a study with two blind conditions (the mash-up
//! study, migration 0015, and the icon-set study, 0019: tables of the same shape), drawn on the
//! first request as the study's next place in its balanced sequence ([`condition_at`]).

use sqlx::Row;

use super::log::{Locked, lock_row};
use super::{Condition, condition_at};
use crate::error::Result;
use crate::store::db::{Backend, Db};
use crate::store::ids::{AssignmentId, StudyId};

/// The table holding a study kind's conditions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConditionTable {
    /// `mashup_conditions`.
    Mashup,
    /// `iconset_conditions`.
    Iconset,
}

impl ConditionTable {
    /// The table's name: one of two constants, never user input.
    fn name(self) -> &'static str {
        match self {
            ConditionTable::Mashup => "mashup_conditions",
            ConditionTable::Iconset => "iconset_conditions",
        }
    }
}

fn read(row: Option<sqlx::any::AnyRow>) -> Result<Option<Condition>> {
    row.map(|r| Condition::from_stored(&r.try_get::<String, _>("condition")?))
        .transpose()
}

/// The condition of `assignment`, if drawn.
pub async fn condition_of(
    db: &Db,
    table: ConditionTable,
    assignment: AssignmentId,
) -> Result<Option<Condition>> {
    let sql = format!(
        "SELECT condition FROM {} WHERE assignment_id = $1",
        table.name()
    );
    let row = sqlx::query(sqlx::AssertSqlSafe(sql))
        .bind(assignment.0)
        .fetch_optional(&db.pool)
        .await?;
    read(row)
}

/// Inside the write transaction `tx`: the condition of `assignment`, drawn and stored now
/// (`true`) unless another request of the same worker already did (`false`). The study's row is
/// locked first, so two assignments can never take the same place in the sequence.
pub(crate) async fn draw_in(
    tx: &mut sqlx::AnyConnection,
    backend: Backend,
    table: ConditionTable,
    study: StudyId,
    seed: u64,
    assignment: AssignmentId,
) -> Result<(Condition, bool)> {
    lock_row(tx, backend, Locked::Study, study.0).await?;
    let name = table.name();
    let existing = sqlx::query(sqlx::AssertSqlSafe(format!(
        "SELECT condition FROM {name} WHERE assignment_id = $1"
    )))
    .bind(assignment.0)
    .fetch_optional(&mut *tx)
    .await?;
    if let Some(c) = read(existing)? {
        return Ok((c, false));
    }
    let next: i64 = sqlx::query(sqlx::AssertSqlSafe(format!(
        "SELECT COALESCE(MAX(seq) + 1, 0) AS next FROM {name} WHERE study_id = $1"
    )))
    .bind(study.0)
    .fetch_one(&mut *tx)
    .await?
    .try_get("next")?;
    let condition = condition_at(seed, next as u64);
    sqlx::query(sqlx::AssertSqlSafe(format!(
        "INSERT INTO {name} (assignment_id, study_id, seq, condition) VALUES ($1, $2, $3, $4)"
    )))
    .bind(assignment.0)
    .bind(study.0)
    .bind(next)
    .bind(condition.as_str())
    .execute(&mut *tx)
    .await?;
    Ok((condition, true))
}
