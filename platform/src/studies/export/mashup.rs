//! The mash-up study's logs in the export (§5.7.3): `mashup_searches.csv`, every result list
//! the server returned, and `mashup_events.csv`, every canvas event it stored (adds with their
//! search and position, removes, undo, redo, layer and background changes) in the order the
//! worker made them. Other kinds of study have none: both files are then a header only.

use std::collections::{BTreeMap, HashMap};

use sqlx::Row;

use super::ExportOptions;
use super::columns::{WORKER_ID, number, text};
use super::data::{Hit, time_cells};
use super::table::Table;
use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::studies::study::Study;

pub(super) const SEARCHES: Table = Table {
    file: "mashup_searches.csv",
    header: true,
    columns: &[
        number("assignment", "assignment id (assignments.csv)"),
        text("worker_id", WORKER_ID),
        text(
            "condition",
            "A (results sorted by style) or B (random order), §5.7.3",
        ),
        number("seq", "the search's number in the HIT, from 1"),
        text("q", "the keywords (empty for none)"),
        text("category", "the style label chosen (empty for any)"),
        text(
            "results",
            "the item names returned, in the order shown, separated by ';'",
        ),
        number("created_at", "Unix ms"),
        text("created_at_utc", "created_at in ISO 8601 UTC"),
    ],
};

pub(super) const EVENTS: Table = Table {
    file: "mashup_events.csv",
    header: true,
    columns: &[
        number("assignment", "assignment id (assignments.csv)"),
        text("worker_id", WORKER_ID),
        text(
            "condition",
            "A (results sorted by style) or B (random order), §5.7.3",
        ),
        number("seq", "the event's number in the HIT, from 1"),
        text(
            "event",
            "add, remove, undo, redo, layer (a piece to another layer) or background",
        ),
        text(
            "item",
            "the piece's item (library item name): add, remove, layer",
        ),
        number(
            "search_seq",
            "add: the search whose list the piece came from (mashup_searches.csv's seq)",
        ),
        number(
            "position",
            "add: the piece's 1-based position in that list (the paper's measure)",
        ),
        number(
            "layer_from",
            "layer: the piece's layer before, 0 the bottom-most",
        ),
        number("layer_to", "layer: its layer after"),
        text(
            "items",
            "undo, redo: the items on the canvas after the step, bottom to top, separated by ';'",
        ),
        text(
            "background",
            "undo, redo, background: the background after the event",
        ),
        number("created_at", "Unix ms"),
        text("created_at_utc", "created_at in ISO 8601 UTC"),
    ],
};

/// The rows of `mashup_searches.csv` and `mashup_events.csv`: the HITs the options include
/// (`hits` by id), oldest HIT first, each HIT's rows in order.
pub(super) async fn rows(
    db: &Db,
    study: &Study,
    opts: ExportOptions,
    hits: &HashMap<i64, &Hit>,
    names: &BTreeMap<i64, String>,
) -> Result<(Vec<Vec<String>>, Vec<Vec<String>>)> {
    let included = |id: i64| {
        hits.get(&id)
            .filter(|h| opts.includes(&h.status, h.decision.as_deref()))
    };
    let name = |id: i64| names.get(&id).cloned().unwrap_or_else(|| id.to_string());
    let list = |ids: &[i64]| ids.iter().map(|&i| name(i)).collect::<Vec<_>>().join(";");
    let mut searches = Vec::new();
    let sql = "SELECT x.assignment_id, c.condition, x.seq, x.q, x.category, x.results, \
                 x.created_at FROM mashup_searches x \
               JOIN assignments a ON a.id = x.assignment_id \
               LEFT JOIN mashup_conditions c ON c.assignment_id = x.assignment_id \
               WHERE a.study_id = $1 ORDER BY a.started_at, a.id, x.seq";
    for r in sqlx::query(sql)
        .bind(study.id.0)
        .fetch_all(&db.pool)
        .await?
    {
        let id: i64 = r.try_get("assignment_id")?;
        let Some(hit) = included(id) else { continue };
        let ids: Vec<i64> = serde_json::from_str(&r.try_get::<String, _>("results")?)
            .map_err(AppError::internal)?;
        let [at, at_utc] = time_cells(Some(r.try_get("created_at")?));
        searches.push(vec![
            id.to_string(),
            hit.worker.clone(),
            r.try_get::<Option<String>, _>("condition")?
                .unwrap_or_default(),
            r.try_get::<i64, _>("seq")?.to_string(),
            r.try_get("q")?,
            r.try_get::<Option<String>, _>("category")?
                .unwrap_or_default(),
            list(&ids),
            at,
            at_utc,
        ]);
    }

    let mut events = Vec::new();
    let sql = "SELECT x.assignment_id, c.condition, x.seq, x.event, x.item_id, x.search_seq, \
                 x.position, x.detail, x.created_at FROM mashup_events x \
               JOIN assignments a ON a.id = x.assignment_id \
               LEFT JOIN mashup_conditions c ON c.assignment_id = x.assignment_id \
               WHERE a.study_id = $1 ORDER BY a.started_at, a.id, x.seq";
    let cell = |v: Option<i64>| v.map(|v| v.to_string()).unwrap_or_default();
    for r in sqlx::query(sql)
        .bind(study.id.0)
        .fetch_all(&db.pool)
        .await?
    {
        let id: i64 = r.try_get("assignment_id")?;
        let Some(hit) = included(id) else { continue };
        let detail: serde_json::Value = match r.try_get::<Option<String>, _>("detail")? {
            Some(d) => serde_json::from_str(&d).map_err(AppError::internal)?,
            None => serde_json::Value::Null,
        };
        let items: Option<Vec<i64>> = detail
            .get("items")
            .map(|v| serde_json::from_value(v.clone()).map_err(AppError::internal))
            .transpose()?;
        let [at, at_utc] = time_cells(Some(r.try_get("created_at")?));
        events.push(vec![
            id.to_string(),
            hit.worker.clone(),
            r.try_get::<Option<String>, _>("condition")?
                .unwrap_or_default(),
            r.try_get::<i64, _>("seq")?.to_string(),
            r.try_get("event")?,
            r.try_get::<Option<i64>, _>("item_id")?
                .map(name)
                .unwrap_or_default(),
            cell(r.try_get("search_seq")?),
            cell(r.try_get("position")?),
            cell(detail.get("from").and_then(serde_json::Value::as_i64)),
            cell(detail.get("to").and_then(serde_json::Value::as_i64)),
            items.as_deref().map(list).unwrap_or_default(),
            detail
                .get("background")
                .and_then(serde_json::Value::as_str)
                .unwrap_or_default()
                .to_string(),
            at,
            at_utc,
        ]);
    }
    Ok((searches, events))
}
