//! Exports of a study: `triplets.csv` in the learner's format (`a,b,c,q,worker,tuple_id`, q = 1
//! when A was judged closer to B, plus `worker_id`), `reasons.csv`, `workers.csv`,
//! `assignments.csv`, `bonuses.csv`, the mash-up study's `mashup_searches.csv` and
//! `mashup_events.csv` and the icon-set study's `iconset_sets.csv` (header only for other
//! kinds), the payment files (`mturk_decisions.csv`
//! for MTurk's batch approve/reject upload, `mturk_bonuses.csv` for `aws mturk send-bonus`,
//! `prolific_bonuses.csv` for Prolific's bulk bonus), the study's report (`report.json`, the
//! report endpoint's body, and `report.csv`, its numbers one per row), `external_question.xml` and
//! `manifest.json` (settings, items in stable order, the data dictionary of every column, and
//! notes on what each option does to each file).
//!
//! Every file names a worker by the id their crowd platform uses (`worker_id`), as the study
//! page does; the `pseudonymous` option swaps it for a pseudonym and leaves the payment files
//! out, for data shared outside the team.

use std::collections::{BTreeMap, HashMap, HashSet};

use serde::{Deserialize, Serialize};

use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::studies::bonus;
use crate::studies::library;
use crate::studies::study::Study;
use crate::time::iso8601;

mod columns;
mod data;
mod iconset;
mod mashup;
mod report;
mod table;

use data::{Counts, Hit, answers, counts, hits, time_cells};

pub use table::neutralise;

/// Which HITs and questions the analysis files hold beyond the default (the main questions of
/// completed, non-rejected HITs), and whether workers are named by a pseudonym. The same
/// options apply to triplets.csv, reasons.csv, workers.csv, assignments.csv and bonuses.csv
/// (the manifest's notes say what each does to each file); the payment files ignore them.
#[derive(Debug, Clone, Copy, Default, Deserialize, utoipa::ToSchema, utoipa::IntoParams)]
#[into_params(parameter_in = Query)]
pub struct ExportOptions {
    /// Also export answers to hidden controls (tuple_id prefixed `control:`) and count them.
    #[serde(default)]
    pub include_controls: bool,
    /// Also export rejected HITs.
    #[serde(default)]
    pub include_rejected: bool,
    /// Also export HITs not completed (in training, answering, screened out, expired, blocked).
    #[serde(default)]
    pub include_incomplete: bool,
    /// Name workers by a pseudonym (HMAC of the study secret) instead of their platform id,
    /// and leave out the payment files: for sharing data outside the research team.
    #[serde(default)]
    pub pseudonymous: bool,
}

impl ExportOptions {
    /// The options as they are named in links and forms, with whether each is set.
    pub fn flags(&self) -> [(&'static str, bool); 4] {
        [
            ("include_controls", self.include_controls),
            ("include_rejected", self.include_rejected),
            ("include_incomplete", self.include_incomplete),
            ("pseudonymous", self.pseudonymous),
        ]
    }

    /// The query string of an export link carrying these options (`""` for the defaults).
    pub fn query(&self) -> String {
        let set: Vec<String> = self
            .flags()
            .iter()
            .filter(|(_, on)| *on)
            .map(|(name, _)| format!("{name}=true"))
            .collect();
        if set.is_empty() {
            String::new()
        } else {
            format!("?{}", set.join("&"))
        }
    }

    /// Whether an analysis file holds a HIT with this status and decision.
    fn includes(&self, status: &str, decision: Option<&str>) -> bool {
        (status == "completed" || self.include_incomplete)
            && (decision != Some("rejected") || self.include_rejected)
    }
}

/// Names of the export files, in the order they are written.
pub const FILES: &[&str] = &[
    "triplets.csv",
    "reasons.csv",
    "workers.csv",
    "assignments.csv",
    "bonuses.csv",
    "mashup_searches.csv",
    "mashup_events.csv",
    "iconset_sets.csv",
    "mturk_decisions.csv",
    "mturk_bonuses.csv",
    "prolific_bonuses.csv",
    "report.json",
    "report.csv",
    "external_question.xml",
    "manifest.json",
];

/// Whether `file` holds the workers' real ids to pay them (left out of pseudonymous exports).
pub fn is_payment_file(file: &str) -> bool {
    columns::PAYMENT_FILES.contains(&file)
}

/// Builds every export file of a study (without the payment files when pseudonymous).
pub async fn build(
    db: &Db,
    study: &Study,
    opts: ExportOptions,
    public_url: &str,
) -> Result<Vec<(String, Vec<u8>)>> {
    let hits = hits(db, study, opts).await?;
    let by_id: HashMap<i64, &Hit> = hits.iter().map(|h| (h.id, h)).collect();
    let counts = counts(db, study).await?;
    let items = library::list_items(db, study.library).await?;
    let names: BTreeMap<i64, String> = items.iter().map(|i| (i.id.0, i.name.clone())).collect();
    let (triplets, reasons) = answers(db, study, opts, &by_id, &names).await?;
    let (mashup_searches, mashup_events) = mashup::rows(db, study, opts, &by_id, &names).await?;
    let iconset_sets = iconset::rows(db, study, opts, &by_id, &names).await?;
    let bonuses = bonus::list(db, study.id).await?;
    let mut bonus_total: HashMap<i64, i64> = HashMap::new();
    for b in &bonuses {
        *bonus_total.entry(b.assignment.0).or_default() += b.amount_cents;
    }

    let (mut workers, mut assignments, mut mturk) = (Vec::new(), Vec::new(), Vec::new());
    let no_counts = Counts::default();
    let blocked_ids: HashSet<&str> = study
        .settings
        .blocked_workers
        .iter()
        .map(String::as_str)
        .collect();
    for h in &hits {
        if h.source == "mturk" && h.status == "completed" {
            let rejected = h.decision.as_deref() == Some("rejected");
            mturk.push(vec![
                h.external_assignment.clone().unwrap_or_default(),
                h.external.clone(),
                h.hit_id.clone().unwrap_or_default(),
                if rejected { "" } else { "x" }.into(),
                if rejected {
                    "Too many wrong answers on check questions with obvious answers.".into()
                } else {
                    String::new()
                },
            ]);
        }
        if !opts.includes(&h.status, h.decision.as_deref()) {
            continue;
        }
        let n = counts.get(&h.id).unwrap_or(&no_counts);
        let (questions, answered) = if opts.include_controls {
            (n.all, n.all_answered)
        } else {
            (n.main, n.main_answered)
        };
        let field = |k: &str| {
            h.demographics
                .get(k)
                .and_then(|v| v.as_str())
                .unwrap_or("")
                .to_string()
        };
        let blocked = blocked_ids.contains(h.external.as_str());
        workers.push(vec![
            h.worker.clone(),
            h.source.clone(),
            h.status.clone(),
            h.decision.clone().unwrap_or_default(),
            answered.to_string(),
            n.control_errors.to_string(),
            h.training_attempts.to_string(),
            bonus::format_cents(bonus_total.get(&h.id).copied().unwrap_or(0)),
            i64::from(blocked).to_string(),
            field("gender"),
            field("art_experience"),
        ]);
        let [started, started_utc] = time_cells(Some(h.started_at));
        let [completed, completed_utc] = time_cells(h.completed_at);
        let [consent_at, consent_at_utc] = time_cells(h.consent_at);
        assignments.push(vec![
            h.id.to_string(),
            h.worker.clone(),
            h.source.clone(),
            h.sandbox.to_string(),
            h.status.clone(),
            h.decision.clone().unwrap_or_default(),
            questions.to_string(),
            answered.to_string(),
            n.control_errors.to_string(),
            started,
            started_utc,
            completed,
            completed_utc,
            h.consent.clone().unwrap_or_default(),
            h.consent_version.clone().unwrap_or_default(),
            consent_at,
            consent_at_utc,
        ]);
    }

    // Oldest first, as the other files list HITs.
    let (mut bonus_rows, mut mturk_bonuses, mut prolific_bonuses) =
        (Vec::new(), Vec::new(), Vec::new());
    for b in bonuses.iter().rev() {
        let token = format!("bonus-{}", b.id);
        match b.source.as_str() {
            "mturk" => mturk_bonuses.push(vec![
                b.worker_id.clone(),
                b.external_assignment.clone().unwrap_or_default(),
                b.amount.clone(),
                b.reason.clone(),
                token.clone(),
            ]),
            "prolific" => prolific_bonuses.push(vec![b.worker_id.clone(), b.amount.clone()]),
            _ => {}
        }
        let Some(hit) = by_id.get(&b.assignment.0) else {
            continue;
        };
        if !opts.includes(&b.status, b.decision.as_deref()) {
            continue;
        }
        let [created, created_utc] = time_cells(Some(b.created_at));
        bonus_rows.push(vec![
            token,
            b.assignment.to_string(),
            hit.worker.clone(),
            b.source.clone(),
            b.amount.clone(),
            b.reason.clone(),
            b.actor.clone(),
            created,
            created_utc,
        ]);
    }

    let manifest_items: Vec<serde_json::Value> = items
        .iter()
        .map(|i| serde_json::json!({"name": i.name, "style": i.style}))
        .collect();
    let files: Vec<&str> = FILES
        .iter()
        .copied()
        .filter(|f| !(opts.pseudonymous && is_payment_file(f)))
        .collect();
    let manifest = serde_json::json!({
        "study": {
            "id": study.id,
            "name": study.name,
            "created_at": study.created_at,
            "created_at_utc": iso8601(study.created_at),
        },
        "settings": study.settings,
        "export_options": {
            "include_controls": opts.include_controls,
            "include_rejected": opts.include_rejected,
            "include_incomplete": opts.include_incomplete,
            "pseudonymous": opts.pseudonymous,
        },
        "counts": {
            "triplets": triplets.len(),
            "reasons": reasons.len(),
            "workers": workers.len(),
            "assignments": assignments.len(),
            "bonuses": bonus_rows.len(),
            "mashup_searches": mashup_searches.len(),
            "mashup_events": mashup_events.len(),
            "iconset_sets": iconset_sets.len(),
        },
        "items": manifest_items,
        "files": files,
        "columns": columns::dictionary(),
        "number_columns": columns::number_columns(),
        "notes": columns::notes(),
    });

    let xml = external_question_xml(&format!(
        "{}/s/{}",
        public_url.trim_end_matches('/'),
        study.id
    ));
    let mut out = vec![
        ("triplets.csv".into(), columns::TRIPLETS.csv(&triplets)?),
        ("reasons.csv".into(), columns::REASONS.csv(&reasons)?),
        ("workers.csv".into(), columns::WORKERS.csv(&workers)?),
        (
            "assignments.csv".into(),
            columns::ASSIGNMENTS.csv(&assignments)?,
        ),
        ("bonuses.csv".into(), columns::BONUSES.csv(&bonus_rows)?),
        (
            "mashup_searches.csv".into(),
            mashup::SEARCHES.csv(&mashup_searches)?,
        ),
        (
            "mashup_events.csv".into(),
            mashup::EVENTS.csv(&mashup_events)?,
        ),
        ("iconset_sets.csv".into(), iconset::SETS.csv(&iconset_sets)?),
    ];
    if !opts.pseudonymous {
        out.push((
            "mturk_decisions.csv".into(),
            columns::MTURK_DECISIONS.csv(&mturk)?,
        ));
        out.push((
            "mturk_bonuses.csv".into(),
            columns::MTURK_BONUSES.csv(&mturk_bonuses)?,
        ));
        out.push((
            "prolific_bonuses.csv".into(),
            columns::PROLIFIC_BONUSES.csv(&prolific_bonuses)?,
        ));
    }
    out.extend(report::files(db, study).await?);
    out.push(("external_question.xml".into(), xml.into_bytes()));
    out.push((
        "manifest.json".into(),
        serde_json::to_vec_pretty(&manifest).map_err(AppError::internal)?,
    ));
    Ok(out)
}

/// One export file by name: 404 for a name that is not an export, 400 for a payment file of a
/// pseudonymous export.
pub async fn file(
    db: &Db,
    study: &Study,
    name: &str,
    opts: ExportOptions,
    public_url: &str,
) -> Result<(String, Vec<u8>)> {
    if !FILES.contains(&name) {
        return Err(AppError::NotFound("export file"));
    }
    if opts.pseudonymous && is_payment_file(name) {
        return Err(AppError::BadRequest(format!(
            "{name} holds the workers' real ids to pay them: it is not part of a pseudonymous \
             export"
        )));
    }
    build(db, study, opts, public_url)
        .await?
        .into_iter()
        .find(|(n, _)| n == name)
        .ok_or(AppError::NotFound("export file"))
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
mod tests;
