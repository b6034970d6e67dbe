//! The icon-set study's sets in the export (Garces et al. 2016 §6.6): `iconset_sets.csv`, one
//! row per finished set with its server-measured time, deletions and searches, and its icons —
//! the rows the report's means are taken over. Other kinds of study have none: the file is
//! then a header only.

use std::collections::{BTreeMap, HashMap};

use super::ExportOptions;
use super::columns::{WORKER_ID, number, text};
use super::data::{Hit, time_cells};
use super::table::Table;
use crate::error::Result;
use crate::store::db::Db;
use crate::studies::iconset::report::{set_rows, settings_of};
use crate::studies::kind::StudyKind;
use crate::studies::study::Study;

pub(super) const SETS: Table = Table {
    file: "iconset_sets.csv",
    header: true,
    columns: &[
        number("assignment", "assignment id (assignments.csv)"),
        text("worker_id", WORKER_ID),
        text(
            "condition",
            "A (the style explorer) or B (the search ordered by style), §6.6",
        ),
        number("set", "the set's number in the HIT, from 1"),
        number(
            "started_at",
            "Unix ms: the task opened (set 1) or the previous set finished",
        ),
        text("started_at_utc", "started_at in ISO 8601 UTC"),
        number("finished_at", "Unix ms: the worker finished the set"),
        text("finished_at_utc", "finished_at in ISO 8601 UTC"),
        number(
            "seconds",
            "finished_at − started_at in seconds (the report's time per set)",
        ),
        number("deletions", "icons removed from the set"),
        number("searches", "searches made while the set was being made"),
        number(
            "spread",
            "the set's style spread: the mean style distance d (eq. 5.5, the study's model) \
             between two of its icons, measured when it was finished",
        ),
        text(
            "labels",
            "the set's slots, in order, separated by ';' (the study's labels)",
        ),
        text(
            "items",
            "the set's icons (library item names), in the order of labels, separated by ';'",
        ),
    ],
};

/// The rows of `iconset_sets.csv`: the sets of the HITs the options include (`hits` by id),
/// oldest HIT first.
pub(super) async fn rows(
    db: &Db,
    study: &Study,
    opts: ExportOptions,
    hits: &HashMap<i64, &Hit>,
    names: &BTreeMap<i64, String>,
) -> Result<Vec<Vec<String>>> {
    if study.kind != StudyKind::Iconset {
        return Ok(Vec::new());
    }
    let labels = settings_of(study)?.labels.join(";");
    let name = |id: i64| names.get(&id).cloned().unwrap_or_else(|| id.to_string());
    let mut out = Vec::new();
    for r in set_rows(db, study, true).await? {
        let Some(hit) = hits
            .get(&r.assignment.0)
            .filter(|h| opts.includes(&h.status, h.decision.as_deref()))
        else {
            continue;
        };
        let [started, started_utc] = time_cells(Some(r.started_at));
        let [finished, finished_utc] = time_cells(Some(r.finished_at));
        out.push(vec![
            r.assignment.to_string(),
            hit.worker.clone(),
            r.condition.as_str().to_string(),
            r.set.to_string(),
            started,
            started_utc,
            finished,
            finished_utc,
            r.seconds.to_string(),
            r.deletions.to_string(),
            r.searches.to_string(),
            r.spread.map(|v| v.to_string()).unwrap_or_default(),
            labels.clone(),
            r.items
                .iter()
                .map(|i| name(i.0))
                .collect::<Vec<_>>()
                .join(";"),
        ]);
    }
    Ok(out)
}
