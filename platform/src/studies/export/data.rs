//! The rows behind the export files: the study's HITs with their workers, question counts
//! per HIT, and the answered questions as rows of `triplets.csv` and `reasons.csv`.

use std::collections::{BTreeMap, HashMap};

use sqlx::Row;

use crate::error::Result;
use crate::store::db::Db;
use crate::store::ids::WorkerId;
use crate::studies::dashboard::pseudonym;
use crate::studies::study::Study;
use crate::time::iso8601;

use super::ExportOptions;

/// One HIT of the study, as the exports need it.
pub(super) struct Hit {
    pub(super) id: i64,
    /// The worker as the files name them (platform id or pseudonym).
    pub(super) worker: String,
    /// The platform id, always (payment files).
    pub(super) external: String,
    pub(super) source: String,
    pub(super) sandbox: i64,
    pub(super) status: String,
    pub(super) decision: Option<String>,
    pub(super) training_attempts: i64,
    pub(super) demographics: serde_json::Value,
    pub(super) started_at: i64,
    pub(super) completed_at: Option<i64>,
    pub(super) external_assignment: Option<String>,
    pub(super) hit_id: Option<String>,
    /// `agreed`, `declined`, or `None` when the study asked for no consent.
    pub(super) consent: Option<String>,
    /// 12 hex digits of the SHA-256 of the consent text answered.
    pub(super) consent_version: Option<String>,
    pub(super) consent_at: Option<i64>,
}

/// Question counts of one HIT.
#[derive(Default)]
pub(super) struct Counts {
    pub(super) main: i64,
    pub(super) main_answered: i64,
    pub(super) all: i64,
    pub(super) all_answered: i64,
    pub(super) control_errors: i64,
}

pub(super) async fn hits(db: &Db, study: &Study, opts: ExportOptions) -> Result<Vec<Hit>> {
    let rows = sqlx::query(
        "SELECT a.id, a.worker_id, w.external_id, a.source, a.sandbox, a.status, a.decision, \
           a.training_attempts, a.demographics, a.started_at, a.completed_at, \
           a.external_assignment, a.hit_id, a.consent, a.consent_version, a.consent_at \
         FROM assignments a JOIN workers w ON w.id = a.worker_id WHERE a.study_id = $1 \
         ORDER BY a.started_at, a.id",
    )
    .bind(study.id.0)
    .fetch_all(&db.pool)
    .await?;
    rows.iter()
        .map(|r| {
            let external: String = r.try_get("external_id")?;
            Ok(Hit {
                id: r.try_get("id")?,
                worker: if opts.pseudonymous {
                    pseudonym(study, WorkerId(r.try_get("worker_id")?))
                } else {
                    external.clone()
                },
                external,
                source: r.try_get("source")?,
                sandbox: r.try_get("sandbox")?,
                status: r.try_get("status")?,
                decision: r.try_get("decision")?,
                training_attempts: r.try_get("training_attempts")?,
                demographics: r
                    .try_get::<Option<String>, _>("demographics")?
                    .and_then(|d| serde_json::from_str(&d).ok())
                    .unwrap_or_default(),
                started_at: r.try_get("started_at")?,
                completed_at: r.try_get("completed_at")?,
                external_assignment: r.try_get("external_assignment")?,
                hit_id: r.try_get("hit_id")?,
                consent: r.try_get("consent")?,
                consent_version: r.try_get("consent_version")?,
                consent_at: r.try_get("consent_at")?,
            })
        })
        .collect()
}

pub(super) async fn counts(db: &Db, study: &Study) -> Result<HashMap<i64, Counts>> {
    let rows = sqlx::query(
        "SELECT q.assignment_id, \
           CAST(SUM(CASE WHEN t.kind = 'main' THEN 1 ELSE 0 END) AS BIGINT) AS main, \
           CAST(SUM(CASE WHEN t.kind = 'main' AND q.choice IS NOT NULL THEN 1 ELSE 0 END) \
             AS BIGINT) AS main_answered, \
           CAST(COUNT(*) AS BIGINT) AS total, \
           CAST(COUNT(q.choice) AS BIGINT) AS answered, \
           CAST(SUM(CASE WHEN t.kind = 'control' \
             AND (q.choice IS NULL OR q.choice <> t.expected) THEN 1 ELSE 0 END) AS BIGINT) \
             AS control_errors \
         FROM questions q JOIN tuples t ON t.id = q.tuple_id \
           JOIN assignments a ON a.id = q.assignment_id \
         WHERE a.study_id = $1 GROUP BY q.assignment_id",
    )
    .bind(study.id.0)
    .fetch_all(&db.pool)
    .await?;
    rows.iter()
        .map(|r| {
            Ok((
                r.try_get("assignment_id")?,
                Counts {
                    main: r.try_get("main")?,
                    main_answered: r.try_get("main_answered")?,
                    all: r.try_get("total")?,
                    all_answered: r.try_get("answered")?,
                    control_errors: r.try_get("control_errors")?,
                },
            ))
        })
        .collect()
}

/// The answered questions' rows of triplets.csv and reasons.csv.
pub(super) async fn answers(
    db: &Db,
    study: &Study,
    opts: ExportOptions,
    hits: &HashMap<i64, &Hit>,
    names: &BTreeMap<i64, String>,
) -> Result<(Vec<Vec<String>>, Vec<Vec<String>>)> {
    let name = |id: i64| names.get(&id).cloned().unwrap_or_else(|| id.to_string());
    let rows = sqlx::query(
        "SELECT q.assignment_id, q.choice, q.reasons, q.reason_text, t.id AS tuple_id, \
         t.kind, t.a, t.b, t.c \
         FROM questions q JOIN tuples t ON t.id = q.tuple_id JOIN assignments a ON a.id = q.assignment_id \
         WHERE a.study_id = $1 AND q.choice IS NOT NULL ORDER BY a.started_at, a.id, q.position",
    )
    .bind(study.id.0)
    .fetch_all(&db.pool)
    .await?;
    let (mut triplets, mut reasons) = (Vec::new(), Vec::new());
    for r in &rows {
        let Some(hit) = hits.get(&r.try_get::<i64, _>("assignment_id")?) else {
            continue;
        };
        let kind: String = r.try_get("kind")?;
        let keep_kind = kind == "main" || (kind == "control" && opts.include_controls);
        if !keep_kind || !opts.includes(&hit.status, hit.decision.as_deref()) {
            continue;
        }
        let tuple: i64 = r.try_get("tuple_id")?;
        let tuple_id = if kind == "main" {
            tuple.to_string()
        } else {
            format!("control:{tuple}")
        };
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
                hit.worker.clone(),
                tuple_id.clone(),
                a.clone(),
                b.clone(),
                c.clone(),
                q.into(),
                codes.join(";"),
                r.try_get::<Option<String>, _>("reason_text")?
                    .unwrap_or_default(),
            ]);
        }
        triplets.push(vec![
            a,
            b,
            c,
            q.into(),
            hit.worker.clone(),
            tuple_id,
            hit.worker.clone(),
        ]);
    }
    Ok((triplets, reasons))
}

pub(super) fn time_cells(ms: Option<i64>) -> [String; 2] {
    match ms {
        Some(ms) => [ms.to_string(), iso8601(ms)],
        None => [String::new(), String::new()],
    }
}
