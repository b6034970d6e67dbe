//! Exports of a study: `triplets.csv` in the learner's format (`a,b,c,q,worker,tuple_id`, q = 1
//! when A was judged closer to B), `reasons.csv`, `workers.csv` (pseudonymous),
//! `assignments.csv`, `mturk_decisions.csv` (MTurk's batch approve/reject upload, with real
//! MTurk ids), `external_question.xml` and `manifest.json` (settings, items in stable order, a
//! data dictionary of every column).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use sqlx::Row;

use crate::dashboard::pseudonym;
use crate::db::Db;
use crate::error::{AppError, Result};
use crate::ids::WorkerId;
use crate::library;
use crate::study::Study;

/// What to include beyond the default (main questions of completed, non-rejected HITs).
#[derive(Debug, Clone, Copy, Default, Deserialize, utoipa::ToSchema, utoipa::IntoParams)]
#[into_params(parameter_in = Query)]
pub struct ExportOptions {
    /// Also export answers to hidden controls (tuple_id prefixed `control:`).
    #[serde(default)]
    pub include_controls: bool,
    /// Also export answers of rejected HITs.
    #[serde(default)]
    pub include_rejected: bool,
    /// Also export answers of HITs not completed yet.
    #[serde(default)]
    pub include_incomplete: bool,
}

/// Names of the export files, in the order they are written.
pub const FILES: &[&str] = &[
    "triplets.csv",
    "reasons.csv",
    "workers.csv",
    "assignments.csv",
    "mturk_decisions.csv",
    "external_question.xml",
    "manifest.json",
];

fn csv_bytes(header: &[&str], rows: Vec<Vec<String>>) -> Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(header).map_err(AppError::internal)?;
    for r in rows {
        w.write_record(&r).map_err(AppError::internal)?;
    }
    w.into_inner().map_err(AppError::internal)
}

/// Column descriptions for the manifest's data dictionary.
const DICTIONARY: &[(&str, &[(&str, &str)])] = &[
    (
        "triplets.csv",
        &[
            ("a", "reference item (library item name)"),
            ("b", "first candidate item"),
            ("c", "second candidate item"),
            (
                "q",
                "1 if the worker judged A closer in style to B, 0 if to C",
            ),
            (
                "worker",
                "pseudonymous worker id (HMAC of the study secret)",
            ),
            ("tuple_id", "id of the triplet; replicated tuples share it"),
        ],
    ),
    (
        "reasons.csv",
        &[
            ("worker", "pseudonymous worker id"),
            ("tuple_id", "triplet id"),
            ("a", "reference item"),
            ("b", "first candidate"),
            ("c", "second candidate"),
            ("q", "1 if B was chosen"),
            (
                "reasons",
                "chosen reason codes separated by ';' (attribute:code)",
            ),
            ("text", "optional free text"),
        ],
    ),
    (
        "workers.csv",
        &[
            ("worker", "pseudonymous worker id"),
            ("source", "mturk, prolific or direct"),
            ("status", "training, active, completed or screened_out"),
            ("decision", "approved, rejected or empty"),
            ("answered", "questions answered"),
            ("control_errors", "wrong or unanswered hidden controls"),
            ("training_attempts", "training attempts used"),
            ("gender", "self-reported, optional"),
            ("art_experience", "none, some or professional (optional)"),
        ],
    ),
    (
        "assignments.csv",
        &[
            ("assignment", "assignment id"),
            ("worker", "pseudonymous worker id"),
            ("source", "mturk, prolific or direct"),
            ("sandbox", "1 for the MTurk sandbox"),
            ("status", "training, active, completed or screened_out"),
            ("decision", "approved, rejected or empty"),
            ("questions", "questions in the HIT"),
            ("answered", "questions answered"),
            ("control_errors", "wrong or unanswered hidden controls"),
            ("started_at", "Unix ms"),
            ("completed_at", "Unix ms or empty"),
        ],
    ),
    (
        "mturk_decisions.csv",
        &[
            ("AssignmentId", "MTurk assignment id (identifying)"),
            ("WorkerId", "MTurk worker id (identifying)"),
            ("HITId", "MTurk HIT id"),
            ("Approve", "x when approved"),
            ("Reject", "rejection reason when rejected"),
        ],
    ),
];

/// Builds every export file of a study.
pub async fn build(
    db: &Db,
    study: &Study,
    opts: ExportOptions,
    public_url: &str,
) -> Result<Vec<(String, Vec<u8>)>> {
    let items = library::list_items(db, study.library).await?;
    let names: BTreeMap<i64, String> = items.iter().map(|i| (i.id.0, i.name.clone())).collect();
    let name = |id: i64| names.get(&id).cloned().unwrap_or_else(|| id.to_string());

    let rows = sqlx::query(
        "SELECT q.assignment_id, q.position, q.choice, q.reasons, q.reason_text, t.id AS tuple_id, \
         t.kind, t.a, t.b, t.c, a.worker_id, a.status, a.decision \
         FROM questions q JOIN tuples t ON t.id = q.tuple_id JOIN assignments a ON a.id = q.assignment_id \
         WHERE a.study_id = $1 AND q.choice IS NOT NULL ORDER BY a.started_at, a.id, q.position",
    )
    .bind(study.id.0)
    .fetch_all(&db.pool)
    .await?;
    let mut triplets = Vec::new();
    let mut reasons = Vec::new();
    for r in &rows {
        let kind: String = r.try_get("kind")?;
        let status: String = r.try_get("status")?;
        let decision: Option<String> = r.try_get("decision")?;
        let worker = pseudonym(study, WorkerId(r.try_get("worker_id")?));
        let tuple: i64 = r.try_get("tuple_id")?;
        let q = if r.try_get::<String, _>("choice")? == "b" {
            "1"
        } else {
            "0"
        };
        let (a, b, c) = (
            name(r.try_get("a")?),
            name(r.try_get("b")?),
            name(r.try_get("c")?),
        );
        if let Some(rs) = r.try_get::<Option<String>, _>("reasons")? {
            let codes: Vec<String> = serde_json::from_str(&rs).unwrap_or_default();
            let codes: Vec<String> = codes
                .iter()
                .map(|code| {
                    let attr = crate::flow::REASONS
                        .iter()
                        .find(|(_, c, _)| c == code)
                        .map_or("other", |(a, _, _)| a);
                    format!("{attr}:{code}")
                })
                .collect();
            reasons.push(vec![
                worker.clone(),
                tuple.to_string(),
                a.clone(),
                b.clone(),
                c.clone(),
                q.into(),
                codes.join(";"),
                r.try_get::<Option<String>, _>("reason_text")?
                    .unwrap_or_default(),
            ]);
        }
        let keep_kind = kind == "main" || (kind == "control" && opts.include_controls);
        let keep_status = status == "completed" || opts.include_incomplete;
        let keep_decision = decision.as_deref() != Some("rejected") || opts.include_rejected;
        if keep_kind && keep_status && keep_decision {
            let tuple_id = if kind == "main" {
                tuple.to_string()
            } else {
                format!("control:{tuple}")
            };
            triplets.push(vec![a, b, c, q.into(), worker, tuple_id]);
        }
    }

    let (_, table) = crate::dashboard::compute(db, study).await?;
    let arows = sqlx::query(
        "SELECT id, worker_id, source, sandbox, status, decision, training_attempts, demographics, \
         started_at, completed_at, external_assignment, hit_id FROM assignments WHERE study_id = $1 \
         ORDER BY started_at, id",
    )
    .bind(study.id.0)
    .fetch_all(&db.pool)
    .await?;
    let wrows = sqlx::query(
        "SELECT w.id, w.external_id FROM workers w WHERE w.id IN \
         (SELECT worker_id FROM assignments WHERE study_id = $1)",
    )
    .bind(study.id.0)
    .fetch_all(&db.pool)
    .await?;
    let external: BTreeMap<i64, String> = wrows
        .iter()
        .map(|r| Ok((r.try_get("id")?, r.try_get("external_id")?)))
        .collect::<Result<_, sqlx::Error>>()?;
    let mut workers = Vec::new();
    let mut assignments = Vec::new();
    let mut mturk = Vec::new();
    for r in &arows {
        let id: i64 = r.try_get("id")?;
        let worker_id: i64 = r.try_get("worker_id")?;
        let stats = table.iter().find(|w| w.assignment == id);
        let (questions, answered, errors) =
            stats.map_or((0, 0, 0), |w| (w.questions, w.answered, w.control_errors));
        let status: String = r.try_get("status")?;
        let decision: Option<String> = r.try_get("decision")?;
        let source: String = r.try_get("source")?;
        let demo: serde_json::Value = r
            .try_get::<Option<String>, _>("demographics")?
            .and_then(|d| serde_json::from_str(&d).ok())
            .unwrap_or_default();
        let field = |k: &str| {
            demo.get(k)
                .and_then(|v| v.as_str())
                .unwrap_or("")
                .to_string()
        };
        let p = pseudonym(study, WorkerId(worker_id));
        workers.push(vec![
            p.clone(),
            source.clone(),
            status.clone(),
            decision.clone().unwrap_or_default(),
            answered.to_string(),
            errors.to_string(),
            r.try_get::<i64, _>("training_attempts")?.to_string(),
            field("gender"),
            field("art_experience"),
        ]);
        assignments.push(vec![
            id.to_string(),
            p,
            source.clone(),
            r.try_get::<i64, _>("sandbox")?.to_string(),
            status.clone(),
            decision.clone().unwrap_or_default(),
            questions.to_string(),
            answered.to_string(),
            errors.to_string(),
            r.try_get::<i64, _>("started_at")?.to_string(),
            r.try_get::<Option<i64>, _>("completed_at")?
                .map(|v| v.to_string())
                .unwrap_or_default(),
        ]);
        if source == "mturk" && status == "completed" {
            let rejected = decision.as_deref() == Some("rejected");
            mturk.push(vec![
                r.try_get::<Option<String>, _>("external_assignment")?
                    .unwrap_or_default(),
                external.get(&worker_id).cloned().unwrap_or_default(),
                r.try_get::<Option<String>, _>("hit_id")?
                    .unwrap_or_default(),
                if rejected { "" } else { "x" }.into(),
                if rejected {
                    "Too many wrong answers on check questions with obvious answers.".into()
                } else {
                    String::new()
                },
            ]);
        }
    }

    let mut manifest_items = Vec::with_capacity(items.len());
    for i in &items {
        manifest_items.push(serde_json::json!({"name": i.name, "style": i.style}));
    }
    let dictionary: serde_json::Map<String, serde_json::Value> = DICTIONARY
        .iter()
        .map(|(file, cols)| {
            (
                file.to_string(),
                serde_json::Value::Object(
                    cols.iter()
                        .map(|(c, d)| (c.to_string(), serde_json::Value::String(d.to_string())))
                        .collect(),
                ),
            )
        })
        .collect();
    let manifest = serde_json::json!({
        "study": {"id": study.id, "name": study.name, "created_at": study.created_at},
        "settings": study.settings,
        "export_options": {
            "include_controls": opts.include_controls,
            "include_rejected": opts.include_rejected,
            "include_incomplete": opts.include_incomplete,
        },
        "counts": {"triplets": triplets.len(), "reasons": reasons.len(), "assignments": assignments.len()},
        "items": manifest_items,
        "files": FILES,
        "columns": dictionary,
        "notes": "workers.csv, assignments.csv, triplets.csv and reasons.csv are pseudonymous; \
                  mturk_decisions.csv holds real MTurk ids for the batch approve/reject upload.",
    });

    let xml = external_question_xml(&format!(
        "{}/s/{}",
        public_url.trim_end_matches('/'),
        study.id
    ));
    let trip_cols = ["a", "b", "c", "q", "worker", "tuple_id"];
    Ok(vec![
        ("triplets.csv".into(), csv_bytes(&trip_cols, triplets)?),
        (
            "reasons.csv".into(),
            csv_bytes(
                &["worker", "tuple_id", "a", "b", "c", "q", "reasons", "text"],
                reasons,
            )?,
        ),
        (
            "workers.csv".into(),
            csv_bytes(
                &[
                    "worker",
                    "source",
                    "status",
                    "decision",
                    "answered",
                    "control_errors",
                    "training_attempts",
                    "gender",
                    "art_experience",
                ],
                workers,
            )?,
        ),
        (
            "assignments.csv".into(),
            csv_bytes(
                &[
                    "assignment",
                    "worker",
                    "source",
                    "sandbox",
                    "status",
                    "decision",
                    "questions",
                    "answered",
                    "control_errors",
                    "started_at",
                    "completed_at",
                ],
                assignments,
            )?,
        ),
        (
            "mturk_decisions.csv".into(),
            csv_bytes(
                &["AssignmentId", "WorkerId", "HITId", "Approve", "Reject"],
                mturk,
            )?,
        ),
        ("external_question.xml".into(), xml.into_bytes()),
        (
            "manifest.json".into(),
            serde_json::to_vec_pretty(&manifest).map_err(AppError::internal)?,
        ),
    ])
}

/// MTurk's ExternalQuestion document pointing at `url` (the study's start page).
pub fn external_question_xml(url: &str) -> String {
    let escaped = url
        .replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;");
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n\
         <ExternalQuestion xmlns=\"http://mechanicalturk.amazonaws.com/AWSMechanicalTurkDataSchemas/2006-07-14/ExternalQuestion.xsd\">\n  \
         <ExternalURL>{escaped}</ExternalURL>\n  <FrameHeight>0</FrameHeight>\n</ExternalQuestion>\n"
    )
}

/// Writes every export file into `dir`.
pub async fn write_dir(
    db: &Db,
    study: &Study,
    opts: ExportOptions,
    public_url: &str,
    dir: &std::path::Path,
) -> Result<Vec<String>> {
    std::fs::create_dir_all(dir).map_err(AppError::internal)?;
    let files = build(db, study, opts, public_url).await?;
    let mut written = Vec::new();
    for (name, bytes) in files {
        std::fs::write(dir.join(&name), bytes).map_err(AppError::internal)?;
        written.push(name);
    }
    Ok(written)
}

/// Serialisable summary for `--json` output.
#[derive(Debug, Serialize)]
pub struct Written {
    /// Files written.
    pub files: Vec<String>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn external_question_escapes_the_url() {
        let x = external_question_xml("https://h/s/1?a=1&b=2");
        assert!(x.contains("<ExternalURL>https://h/s/1?a=1&amp;b=2</ExternalURL>"));
    }
}
