//! The events a worker's canvas posts (`POST …/mashup/events`, `data-log-url` of mashup.js) and
//! how each is checked before it is stored in `mashup_events` (migrations 0015 and 0016).
//!
//! The measure of §5.7.3 needs the adds (which list a piece came from, at which position) and
//! the removes; the other edits a researcher analyses — undo and redo, layer changes, the
//! background — are logged beside them, in the same numbered sequence, so the whole session
//! can be replayed from the export (`mashup_events.csv`). The schema is closed: an unknown
//! `event` or field is a 400 before anything is read from the database.

use serde::{Deserialize, Serialize};
use sqlx::Row;

use super::log::{Locked, events, lock_row, replay, search_results};
use crate::error::{AppError, Result};
use crate::mashup::backgrounds;
use crate::mashup::document::MAX_PIECES;
use crate::store::db::{Db, now_ms};
use crate::store::ids::{AssignmentId, ItemId};

// The OpenAPI bounds of `Event` (layers 0..=199, at most 200 items) are MAX_PIECES's.
const _: () = assert!(MAX_PIECES == 200);

/// An event the canvas posts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(tag = "event", rename_all = "lowercase", deny_unknown_fields)]
pub enum Event {
    /// A search the page shows: must be one the server answered, with the same list (the
    /// server logged it when it answered, so this only confirms it).
    Search {
        /// The search's number (from the search response).
        seq: i64,
        /// The query text.
        q: String,
        /// The category, if any.
        #[serde(default)]
        category: Option<String>,
        /// The ids shown, in order.
        results: Vec<ItemId>,
    },
    /// A piece dragged or clicked onto the canvas.
    Add {
        /// The item.
        item: ItemId,
        /// The search whose list it came from.
        search_seq: i64,
        /// Its 1-based position in that list.
        #[schema(minimum = 1)]
        position: i64,
    },
    /// A piece deleted from the canvas (Delete button, Delete or Backspace key).
    Remove {
        /// The item.
        item: ItemId,
    },
    /// Undo (button, Ctrl+Z): the canvas as the step left it.
    Undo {
        /// The items of the pieces on the canvas after the step, bottom to top.
        #[schema(max_items = 200)]
        items: Vec<ItemId>,
        /// The background after the step.
        background: String,
    },
    /// Redo (button, Ctrl+Shift+Z or Ctrl+Y): the canvas as the step left it.
    Redo {
        /// The items of the pieces on the canvas after the step, bottom to top.
        #[schema(max_items = 200)]
        items: Vec<ItemId>,
        /// The background after the step.
        background: String,
    },
    /// A piece moved to another layer (Top, Up, Down, Bottom).
    Layer {
        /// The piece's item.
        item: ItemId,
        /// Its layer before, 0 the bottom-most piece.
        #[schema(minimum = 0, maximum = 199)]
        from: i64,
        /// Its layer after.
        #[schema(minimum = 0, maximum = 199)]
        to: i64,
    },
    /// The background chosen in the drop-down.
    Background {
        /// The background's name (`mashup::backgrounds`).
        background: String,
    },
}

impl Event {
    /// The name stored in `mashup_events.event` (the JSON tag).
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Search { .. } => "search",
            Self::Add { .. } => "add",
            Self::Remove { .. } => "remove",
            Self::Undo { .. } => "undo",
            Self::Redo { .. } => "redo",
            Self::Layer { .. } => "layer",
            Self::Background { .. } => "background",
        }
    }

    /// The background the event sets, if any.
    fn background(&self) -> Option<&str> {
        match self {
            Self::Undo { background, .. }
            | Self::Redo { background, .. }
            | Self::Background { background } => Some(background),
            _ => None,
        }
    }
}

/// Whether `item` is at 1-based `position` of `results` (a 400 saying what is there otherwise).
pub fn check_add(results: &[ItemId], item: ItemId, position: i64) -> Result<()> {
    let at = usize::try_from(position)
        .ok()
        .and_then(|p| p.checked_sub(1))
        .and_then(|i| results.get(i));
    match at {
        Some(&found) if found == item => Ok(()),
        Some(&found) => Err(AppError::BadRequest(format!(
            "add: position {position} of that search is item {found}, not {item}"
        ))),
        None => Err(AppError::BadRequest(format!(
            "add: position {position} is not in 1..={} of that search",
            results.len()
        ))),
    }
}

/// Whether the background an event sets is one of the canvas's and, when the study fixes the
/// background (`fixed`), that one: the page hides the drop-down then, so another is a 400.
pub fn check_background(event: &Event, fixed: Option<&str>) -> Result<()> {
    let Some(name) = event.background() else {
        return Ok(());
    };
    let kind = event.kind();
    if backgrounds::by_name(name).is_none() {
        return Err(AppError::BadRequest(format!(
            "{kind}: unknown background {name:?}"
        )));
    }
    match fixed {
        Some(f) if f != name => Err(AppError::BadRequest(format!(
            "{kind}: the task's background is {f:?}, not {name:?}"
        ))),
        _ => Ok(()),
    }
}

/// Whether a layer index is one a canvas can have.
fn check_layer(field: &str, value: i64) -> Result<()> {
    if (0..MAX_PIECES as i64).contains(&value) {
        Ok(())
    } else {
        Err(AppError::BadRequest(format!(
            "layer: {field} {value} is not in 0..{MAX_PIECES}"
        )))
    }
}

/// What is stored of an event besides its kind: the item, the search and position of an add,
/// and the other fields as JSON (`detail`).
struct Stored {
    item: Option<ItemId>,
    search_seq: Option<i64>,
    position: Option<i64>,
    detail: Option<serde_json::Value>,
}

/// Validates `event` against the server's log of `assignment` and stores it (a `search` event
/// is only checked: the search was logged when it was answered). Every item an event names
/// must have been added from a result list the server returned.
pub async fn record_event(db: &Db, assignment: AssignmentId, event: &Event) -> Result<()> {
    let unknown = |seq: i64| AppError::BadRequest(format!("no search {seq} was answered"));
    let kind = event.kind();
    let stored = match event {
        Event::Search {
            seq,
            q,
            category,
            results,
        } => {
            let (logged_q, logged_category, logged) = search_results(db, assignment, *seq)
                .await?
                .ok_or_else(|| unknown(*seq))?;
            // The page sends an empty category as "", the log holds none.
            let category = category.as_deref().map(str::trim).filter(|c| !c.is_empty());
            if (logged_q.as_str(), logged_category.as_deref(), &logged)
                != (q.trim(), category, results)
            {
                return Err(AppError::BadRequest(format!(
                    "search {seq}: the query or list differs from what the server returned"
                )));
            }
            return Ok(());
        }
        Event::Add {
            item,
            search_seq,
            position,
        } => {
            let (_, _, results) = search_results(db, assignment, *search_seq)
                .await?
                .ok_or_else(|| unknown(*search_seq))?;
            check_add(&results, *item, *position)?;
            Stored {
                item: Some(*item),
                search_seq: Some(*search_seq),
                position: Some(*position),
                detail: None,
            }
        }
        Event::Remove { item } => {
            // Lenient about how many: an undo may have brought back a removed piece.
            added(db, assignment, kind, &[*item]).await?;
            Stored {
                item: Some(*item),
                search_seq: None,
                position: None,
                detail: None,
            }
        }
        Event::Undo { items, background } | Event::Redo { items, background } => {
            if items.len() > MAX_PIECES {
                return Err(AppError::BadRequest(format!(
                    "{kind}: {} items, a canvas holds at most {MAX_PIECES}",
                    items.len()
                )));
            }
            check_background(event, None)?;
            added(db, assignment, kind, items).await?;
            Stored {
                item: None,
                search_seq: None,
                position: None,
                detail: Some(serde_json::json!({"items": items, "background": background})),
            }
        }
        Event::Layer { item, from, to } => {
            check_layer("from", *from)?;
            check_layer("to", *to)?;
            if from == to {
                return Err(AppError::BadRequest(format!(
                    "layer: from and to are both {from}"
                )));
            }
            added(db, assignment, kind, &[*item]).await?;
            Stored {
                item: Some(*item),
                search_seq: None,
                position: None,
                detail: Some(serde_json::json!({"from": from, "to": to})),
            }
        }
        Event::Background { background } => {
            check_background(event, None)?;
            Stored {
                item: None,
                search_seq: None,
                position: None,
                detail: Some(serde_json::json!({ "background": background })),
            }
        }
    };
    insert(db, assignment, kind, stored).await
}

/// A 400 unless every one of `items` was added from a result list of `assignment`.
async fn added(db: &Db, assignment: AssignmentId, kind: &str, items: &[ItemId]) -> Result<()> {
    let canvas = replay(&events(db, assignment).await?);
    match items.iter().find(|i| !canvas.all.contains_key(i)) {
        Some(item) => Err(AppError::BadRequest(format!(
            "{kind}: item {item} was never added from search results"
        ))),
        None => Ok(()),
    }
}

/// Stores one event as the assignment's next (`seq` numbered under the assignment's lock).
async fn insert(db: &Db, assignment: AssignmentId, kind: &str, row: Stored) -> Result<()> {
    let detail = row.detail.map(|d| d.to_string());
    let mut tx = db.begin_write().await?;
    lock_row(&mut tx, db.backend, Locked::Assignment, assignment.0).await?;
    let seq: i64 = sqlx::query(
        "SELECT COALESCE(MAX(seq), 0) + 1 AS next FROM mashup_events WHERE assignment_id = $1",
    )
    .bind(assignment.0)
    .fetch_one(&mut *tx)
    .await?
    .try_get("next")?;
    sqlx::query(
        "INSERT INTO mashup_events \
         (assignment_id, seq, event, item_id, search_seq, position, detail, created_at) \
         VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
    )
    .bind(assignment.0)
    .bind(seq)
    .bind(kind)
    .bind(row.item.map(|i| i.0))
    .bind(row.search_seq)
    .bind(row.position)
    .bind(detail)
    .bind(now_ms())
    .execute(&mut *tx)
    .await?;
    tx.commit().await?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_add_must_name_the_item_at_its_position() {
        let results = [ItemId(5), ItemId(9), ItemId(2)];
        check_add(&results, ItemId(5), 1).unwrap();
        check_add(&results, ItemId(2), 3).unwrap();
        for (item, position) in [(5, 2), (2, 4), (5, 0), (5, -1), (7, 1)] {
            assert!(
                matches!(
                    check_add(&results, ItemId(item), position),
                    Err(AppError::BadRequest(_))
                ),
                "item {item} at {position} accepted"
            );
        }
    }

    #[test]
    fn events_parse_as_mashup_js_posts_them() {
        let add: Event =
            serde_json::from_str(r#"{"event":"add","item":7,"search_seq":2,"position":3}"#)
                .unwrap();
        assert_eq!(
            add,
            Event::Add {
                item: ItemId(7),
                search_seq: 2,
                position: 3
            }
        );
        let search: Event = serde_json::from_str(
            r#"{"event":"search","seq":1,"q":"cat","category":null,"results":[1,2]}"#,
        )
        .unwrap();
        assert!(matches!(search, Event::Search { seq: 1, .. }));
        let parse = |s: &str| serde_json::from_str::<Event>(s);
        assert!(parse(r#"{"event":"remove","item":7}"#).is_ok());
        let undo = parse(r#"{"event":"undo","items":[7,3],"background":"grass"}"#).unwrap();
        assert_eq!(undo.kind(), "undo");
        assert_eq!(
            parse(r#"{"event":"layer","item":7,"from":0,"to":2}"#).unwrap(),
            Event::Layer {
                item: ItemId(7),
                from: 0,
                to: 2
            }
        );
        assert!(parse(r#"{"event":"background","background":"cat"}"#).is_ok());
        for bad in [
            r#"{"event":"move","item":7}"#,
            r#"{"event":"remove","item":7,"x":1}"#,
            r#"{"event":"redo","items":[7]}"#,
            r#"{"event":"layer","item":7,"from":0}"#,
            r#"{"event":"background"}"#,
            r#"{"item":7}"#,
        ] {
            assert!(parse(bad).is_err(), "{bad} accepted");
        }
    }

    #[test]
    fn backgrounds_must_exist_and_match_a_fixed_one() {
        let bg = |b: &str| Event::Background {
            background: b.into(),
        };
        check_background(&bg("grass"), None).unwrap();
        check_background(&bg("grass"), Some("grass")).unwrap();
        assert!(check_background(&bg("moon"), None).is_err());
        assert!(check_background(&bg("cat"), Some("grass")).is_err());
        let undo = Event::Undo {
            items: vec![],
            background: "blank".into(),
        };
        assert!(check_background(&undo, Some("grass")).is_err());
        check_background(&Event::Remove { item: ItemId(1) }, Some("grass")).unwrap();
    }
}
