//! The mash-up study's log (migration 0015): each assignment's condition, every search the
//! server answered with the list it returned, every piece added or removed, the submission.
//! The events the canvas posts, and how each is checked, are [`super::events`].
//!
//! Positions cannot be faked: an `add` names the search it came from and its 1-based position
//! in that list, and is accepted only when the server's own record of that list has that item
//! at that position. The positions of the pieces in a submitted composition are replayed from
//! the events (a `remove` takes back the latest `add` of its item), so every piece used has
//! exactly one logged position.

use std::collections::HashMap;

use sqlx::Row;

use super::Condition;
use super::drawn::{self, ConditionTable};
pub use super::events::{Event, check_add, check_background, record_event};
use crate::error::{AppError, Result};
use crate::store::db::{Backend, Db, now_ms};
use crate::store::ids::{AssignmentId, ItemId, StudyId};

/// Longest logged query text, in characters (longer searches are refused before they run).
pub const MAX_QUERY_CHARS: usize = 200;

/// A stored add or remove, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Logged {
    /// Added from a result list.
    Add {
        /// The item.
        item: ItemId,
        /// Its 1-based position in that list.
        position: i64,
    },
    /// Removed.
    Remove {
        /// The item.
        item: ItemId,
    },
}

/// What the logged events say about the canvas: per item, the positions of the pieces still
/// on it (a remove takes back the latest add) and of every add.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Canvas {
    /// Per item, the positions of its pieces not removed since, oldest first.
    pub net: HashMap<ItemId, Vec<i64>>,
    /// Per item, the positions of all its adds, oldest first.
    pub all: HashMap<ItemId, Vec<i64>>,
}

/// Replays `events`.
pub fn replay(events: &[Logged]) -> Canvas {
    let mut c = Canvas::default();
    for e in events {
        match *e {
            Logged::Add { item, position } => {
                c.net.entry(item).or_default().push(position);
                c.all.entry(item).or_default().push(position);
            }
            Logged::Remove { item } => {
                c.net.get_mut(&item).and_then(Vec::pop);
            }
        }
    }
    c
}

/// The logged position of each piece of a document whose pieces are the items `pieces`: for
/// an item used k times, the latest k of its pieces still on the canvas, or — when the
/// canvas's undo and redo brought back removed pieces — the latest k of its adds. (Undo and
/// redo are logged with the items they leave, for analysis; the positions keep this rule, so
/// each is the position of an add the server checked.) A piece whose item was added from search results fewer times than
/// it is used is a 400: every piece used must have a position the server checked.
pub fn positions(pieces: &[ItemId], canvas: &Canvas) -> Result<Vec<i64>> {
    let mut uses: HashMap<ItemId, usize> = HashMap::new();
    for &item in pieces {
        *uses.entry(item).or_default() += 1;
    }
    let mut items: Vec<(ItemId, usize)> = uses.into_iter().collect();
    items.sort_unstable();
    let mut out = Vec::with_capacity(pieces.len());
    for (item, k) in items {
        let empty = Vec::new();
        let net = canvas.net.get(&item).unwrap_or(&empty);
        let all = canvas.all.get(&item).unwrap_or(&empty);
        let from = if net.len() >= k { net } else { all };
        if from.len() < k {
            return Err(AppError::BadRequest(format!(
                "document: item {item} is used {k} times but was added from search results {} \
                 times",
                all.len()
            )));
        }
        out.extend_from_slice(&from[from.len() - k..]);
    }
    Ok(out)
}

/// On PostgreSQL, locks the row `id` of `table` for the rest of the transaction, so that
/// writers numbering rows under it (`MAX(seq) + 1`) take turns; SQLite's `BEGIN IMMEDIATE`
/// (`Db::begin_write`) already serialises every writer.
pub(crate) async fn lock_row(
    tx: &mut sqlx::AnyConnection,
    backend: Backend,
    table: Locked,
    id: i64,
) -> Result<()> {
    if backend == Backend::Postgres {
        let sql = match table {
            Locked::Assignment => "SELECT id FROM assignments WHERE id = $1 FOR UPDATE",
            Locked::Study => "SELECT id FROM studies WHERE id = $1 FOR UPDATE",
        };
        sqlx::query(sql).bind(id).fetch_optional(&mut *tx).await?;
    }
    Ok(())
}

/// The rows [`lock_row`] locks.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Locked {
    /// `assignments`: its searches, events and submission are numbered or checked under it.
    Assignment,
    /// `studies`: its conditions are numbered under it.
    Study,
}

/// The condition of `assignment`, drawing it (the study's next place in its balanced sequence,
/// [`condition_at`](super::condition_at)) on the first call.
pub async fn assign_condition(
    db: &Db,
    study: StudyId,
    seed: u64,
    assignment: AssignmentId,
) -> Result<Condition> {
    if let Some(c) = condition_of(db, assignment).await? {
        return Ok(c);
    }
    let mut tx = db.begin_write().await?;
    let (condition, drawn) = drawn::draw_in(
        &mut tx,
        db.backend,
        ConditionTable::Mashup,
        study,
        seed,
        assignment,
    )
    .await?;
    if drawn {
        tx.commit().await?;
    }
    Ok(condition)
}

/// The condition of `assignment`, if drawn.
pub async fn condition_of(db: &Db, assignment: AssignmentId) -> Result<Option<Condition>> {
    drawn::condition_of(db, ConditionTable::Mashup, assignment).await
}

/// Logs a search the server answered and returns its number (1, 2, … per assignment).
pub async fn record_search(
    db: &Db,
    assignment: AssignmentId,
    q: &str,
    category: Option<&str>,
    results: &[ItemId],
) -> Result<i64> {
    let results = serde_json::to_string(results).map_err(AppError::internal)?;
    // Stored as the search read them: trimmed, an empty category as none.
    let q = q.trim();
    let category = category.map(str::trim).filter(|c| !c.is_empty());
    let mut tx = db.begin_write().await?;
    lock_row(&mut tx, db.backend, Locked::Assignment, assignment.0).await?;
    let seq: i64 = sqlx::query(
        "SELECT COALESCE(MAX(seq), 0) + 1 AS next FROM mashup_searches WHERE assignment_id = $1",
    )
    .bind(assignment.0)
    .fetch_one(&mut *tx)
    .await?
    .try_get("next")?;
    sqlx::query(
        "INSERT INTO mashup_searches (assignment_id, seq, q, category, results, created_at) \
         VALUES ($1, $2, $3, $4, $5, $6)",
    )
    .bind(assignment.0)
    .bind(seq)
    .bind(q)
    .bind(category.map(str::to_string))
    .bind(results)
    .bind(now_ms())
    .execute(&mut *tx)
    .await?;
    tx.commit().await?;
    Ok(seq)
}

/// The list search `seq` of `assignment` returned (`None`: no such search).
pub async fn search_results(
    db: &Db,
    assignment: AssignmentId,
    seq: i64,
) -> Result<Option<(String, Option<String>, Vec<ItemId>)>> {
    let row = sqlx::query(
        "SELECT q, category, results FROM mashup_searches WHERE assignment_id = $1 AND seq = $2",
    )
    .bind(assignment.0)
    .bind(seq)
    .fetch_optional(&db.pool)
    .await?;
    let Some(r) = row else { return Ok(None) };
    let results: Vec<ItemId> =
        serde_json::from_str(&r.try_get::<String, _>("results")?).map_err(AppError::internal)?;
    Ok(Some((r.try_get("q")?, r.try_get("category")?, results)))
}

/// The number of searches `assignment` made.
pub async fn search_count(db: &Db, assignment: AssignmentId) -> Result<i64> {
    Ok(sqlx::query(
        "SELECT CAST(COUNT(*) AS BIGINT) AS n FROM mashup_searches WHERE assignment_id = $1",
    )
    .bind(assignment.0)
    .fetch_one(&db.pool)
    .await?
    .try_get("n")?)
}

/// The adds and removes of `assignment`, in order (the other canvas edits do not change which
/// list a piece came from).
pub async fn events(db: &Db, assignment: AssignmentId) -> Result<Vec<Logged>> {
    let rows = sqlx::query(
        "SELECT event, item_id, position FROM mashup_events \
         WHERE assignment_id = $1 AND event IN ('add', 'remove') ORDER BY seq",
    )
    .bind(assignment.0)
    .fetch_all(&db.pool)
    .await?;
    rows.iter()
        .map(|r| {
            let item = ItemId(r.try_get("item_id")?);
            match r.try_get::<String, _>("event")?.as_str() {
                "add" => Ok(Logged::Add {
                    item,
                    position: r.try_get("position")?,
                }),
                "remove" => Ok(Logged::Remove { item }),
                other => Err(AppError::Internal(format!(
                    "mashup_events: unknown event {other:?}"
                ))),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pieces_take_the_positions_of_the_latest_adds_of_their_item() {
        let add = |item, position| Logged::Add {
            item: ItemId(item),
            position,
        };
        let remove = |item| Logged::Remove { item: ItemId(item) };
        let c = replay(&[
            add(1, 4),
            add(2, 7),
            add(1, 12),
            remove(1),
            remove(2),
            remove(9),
        ]);
        assert_eq!(c.net[&ItemId(1)], vec![4]);
        assert!(c.net[&ItemId(2)].is_empty());
        assert_eq!(c.all[&ItemId(1)], vec![4, 12]);
        let mut p = positions(&[ItemId(1)], &c).unwrap();
        assert_eq!(p, vec![4]);
        // Two pieces of item 1: more than on the canvas (an unlogged undo of the remove), so
        // the latest two adds; item 2 likewise brought back.
        p = positions(&[ItemId(2), ItemId(1), ItemId(1)], &c).unwrap();
        p.sort_unstable();
        assert_eq!(p, vec![4, 7, 12]);
        assert!(positions(&[ItemId(1), ItemId(1), ItemId(1)], &c).is_err());
        assert!(positions(&[ItemId(3)], &c).is_err());
    }
}
