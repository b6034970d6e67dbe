//! The icon-set study's log (migration 0019): each assignment's condition and every event with
//! the server's time. What the worker asks ([`Action`]) is checked against the tray replayed
//! from the log inside the same write transaction, so two requests of one worker cannot both
//! fill a slot, and the time per set is measured here — set 1 starts when the worker first
//! opens the task, set k + 1 when set k is finished — never taken from the client.
//!
//! The pure part — the tray replayed from the events and the check of a step — is [`tray`].

mod tray;

use sqlx::Row;

pub use tray::{Action, Kind, Logged, SetState, Tray, check, replay, spread};

use super::{Condition, IconsetSettings};
use crate::error::{AppError, Result};
use crate::search::cache::Built;
use crate::store::db::{Db, now_ms};
use crate::store::ids::{AssignmentId, ItemId, LibraryId, StudyId};
use crate::studies::mashup::drawn::{self, ConditionTable};
use crate::studies::mashup::log::{Locked, lock_row};

async fn read(conn: &mut sqlx::AnyConnection, assignment: AssignmentId) -> Result<Vec<Logged>> {
    let rows = sqlx::query(
        "SELECT event, set_index, label, item_id, detail, created_at FROM iconset_events \
         WHERE assignment_id = $1 ORDER BY seq",
    )
    .bind(assignment.0)
    .fetch_all(&mut *conn)
    .await?;
    rows.iter()
        .map(|r| {
            Ok(Logged {
                kind: Kind::from_stored(&r.try_get::<String, _>("event")?)?,
                set: r.try_get::<i64, _>("set_index")? as usize,
                label: r.try_get("label")?,
                item: r.try_get::<Option<i64>, _>("item_id")?.map(ItemId),
                at: r.try_get("created_at")?,
                spread: r
                    .try_get::<Option<String>, _>("detail")?
                    .and_then(|d| serde_json::from_str::<serde_json::Value>(&d).ok())
                    .and_then(|d| d.get("spread").and_then(serde_json::Value::as_f64)),
            })
        })
        .collect()
}

async fn insert(
    conn: &mut sqlx::AnyConnection,
    assignment: AssignmentId,
    e: &Logged,
    detail: Option<String>,
) -> Result<()> {
    let seq: i64 = sqlx::query(
        "SELECT COALESCE(MAX(seq), 0) + 1 AS next FROM iconset_events WHERE assignment_id = $1",
    )
    .bind(assignment.0)
    .fetch_one(&mut *conn)
    .await?
    .try_get("next")?;
    sqlx::query(
        "INSERT INTO iconset_events \
         (assignment_id, seq, event, set_index, label, item_id, detail, created_at) \
         VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
    )
    .bind(assignment.0)
    .bind(seq)
    .bind(e.kind.as_str())
    .bind(e.set as i64)
    .bind(e.label.clone())
    .bind(e.item.map(|i| i.0))
    .bind(detail)
    .bind(e.at)
    .execute(&mut *conn)
    .await?;
    Ok(())
}

/// The events of `assignment`, in order.
pub async fn events(db: &Db, assignment: AssignmentId) -> Result<Vec<Logged>> {
    let mut conn = db.pool.acquire().await?;
    read(&mut conn, assignment).await
}

/// The tray of `assignment`.
pub async fn tray(db: &Db, settings: &IconsetSettings, assignment: AssignmentId) -> Result<Tray> {
    Ok(replay(
        &settings.labels,
        settings.sets,
        &events(db, assignment).await?,
    ))
}

/// The condition of `assignment`, if drawn.
pub async fn condition_of(db: &Db, assignment: AssignmentId) -> Result<Option<Condition>> {
    drawn::condition_of(db, ConditionTable::Iconset, assignment).await
}

/// The condition of `assignment`. On the first call it is drawn (the study's next place in
/// its balanced sequence) and the task's `open` event is logged in the same transaction: set 1
/// starts now.
pub async fn start(
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
        ConditionTable::Iconset,
        study,
        seed,
        assignment,
    )
    .await?;
    if !drawn {
        return Ok(condition);
    }
    let open = Logged {
        kind: Kind::Open,
        set: 1,
        label: None,
        item: None,
        at: now_ms(),
        spread: None,
    };
    insert(&mut tx, assignment, &open, None).await?;
    tx.commit().await?;
    Ok(condition)
}

/// The label of `item` if it is an item of `library` (`None`: unlabelled); a 400 otherwise.
async fn item_label(db: &Db, library: LibraryId, item: ItemId) -> Result<Option<String>> {
    let row = sqlx::query("SELECT style FROM items WHERE id = $1 AND library_id = $2")
        .bind(item.0)
        .bind(library.0)
        .fetch_optional(&db.pool)
        .await?
        .ok_or_else(|| {
            AppError::BadRequest(format!("item {item} is not an item of the study's library"))
        })?;
    Ok(row.try_get("style")?)
}

/// Checks `action` against the logged tray and logs it; returns the tray after it. A finished
/// set's [`spread`] is measured in `index` (the search index of the study's library and model)
/// and stored with the event.
pub async fn act(
    db: &Db,
    library: LibraryId,
    settings: &IconsetSettings,
    assignment: AssignmentId,
    action: &Action,
    index: Option<&Built>,
) -> Result<Tray> {
    let label = match action {
        Action::Add { item } => item_label(db, library, *item).await?,
        _ => None,
    };
    let mut tx = db.begin_write().await?;
    lock_row(&mut tx, db.backend, Locked::Assignment, assignment.0).await?;
    let mut events = read(&mut tx, assignment).await?;
    let tray = replay(&settings.labels, settings.sets, &events);
    let mut event = check(settings, &tray, action, label.as_deref())?;
    let mut detail = None;
    if event.kind == Kind::Finish
        && let (Some(built), Some(c)) = (index, tray.current())
    {
        let items: Vec<ItemId> = tray.sets[c].slots.iter().flatten().copied().collect();
        event.spread = spread(built, &items);
        detail = event
            .spread
            .map(|s| serde_json::json!({ "spread": s }).to_string());
    }
    insert(&mut tx, assignment, &event, detail).await?;
    tx.commit().await?;
    events.push(event);
    Ok(replay(&settings.labels, settings.sets, &events))
}

/// Logs a search answered for `assignment` (its keywords, label and the item ids returned, in
/// order), counted in the current set.
pub async fn record_search(
    db: &Db,
    settings: &IconsetSettings,
    assignment: AssignmentId,
    q: &str,
    label: &str,
    results: &[ItemId],
) -> Result<()> {
    let detail = serde_json::json!({"q": q, "label": label, "results": results}).to_string();
    let mut tx = db.begin_write().await?;
    lock_row(&mut tx, db.backend, Locked::Assignment, assignment.0).await?;
    let events = read(&mut tx, assignment).await?;
    let tray = replay(&settings.labels, settings.sets, &events);
    let set = tray.current().map_or(settings.sets as usize, |c| c + 1);
    let e = Logged {
        kind: Kind::Search,
        set,
        label: Some(label.to_owned()),
        item: None,
        at: now_ms(),
        spread: None,
    };
    insert(&mut tx, assignment, &e, Some(detail)).await?;
    tx.commit().await?;
    Ok(())
}
