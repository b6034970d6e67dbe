//! Study statistics for the dashboard and `platform study status`: assignment counts,
//! rejection rate, control-accuracy histogram, agreement on replicated tuples (with the majority
//! and the leave-one-out noise ceiling), median seconds per question, answers over time, and the
//! per-worker table (newest HIT first, each worker named by their crowd platform's id).
//! Computed from the stored rows on every request (no in-process state).

use std::collections::{BTreeMap, HashMap, HashSet};

use hmac::{Hmac, Mac};
use serde::Serialize;
use sha2::Sha256;
use sqlx::Row;
use utoipa::ToSchema;

use crate::error::Result;
use crate::store::db::Db;
use crate::store::ids::WorkerId;
use crate::studies::study::Study;

/// A worker's pseudonym for data shared outside the research team (the `pseudonymous` export
/// option): HMAC of the study secret and the worker's row id, stable within a study and not
/// linkable to the crowd platform's id without the secret.
pub fn pseudonym(study: &Study, worker: WorkerId) -> String {
    let Ok(mut mac) = Hmac::<Sha256>::new_from_slice(study.secret.as_bytes()) else {
        return String::new();
    };
    mac.update(b"worker:");
    mac.update(worker.0.to_string().as_bytes());
    format!("W{}", hex::encode(&mac.finalize().into_bytes()[..5]))
}

/// The dashboard numbers of one study.
#[derive(Debug, Clone, Default, Serialize, ToSchema)]
pub struct Dashboard {
    /// Assignments started.
    pub started: i64,
    /// Still in training.
    pub in_training: i64,
    /// Answering questions.
    pub active: i64,
    /// Completed HITs.
    pub completed: i64,
    /// Screened out in training.
    pub screened_out: i64,
    /// Did not give consent (no HIT).
    pub declined: i64,
    /// Expired before finishing (slots released).
    pub abandoned: i64,
    /// Completed and approved.
    pub approved: i64,
    /// Completed and rejected.
    pub rejected: i64,
    /// rejected / completed.
    pub rejection_rate: Option<f64>,
    /// Completed HITs by number of control errors, fewest errors first.
    pub control_error_histogram: Vec<ErrorCount>,
    /// Slots in the study (main tuples × R).
    pub slots: i64,
    /// Slots claimed by an assignment.
    pub slots_claimed: i64,
    /// Main answers stored (all assignments).
    pub answers: i64,
    /// Tuples with at least two answers from non-rejected HITs.
    pub replicated_tuples: i64,
    /// Mean agreement of an answer with its tuple's majority.
    pub agreement_with_majority: Option<f64>,
    /// Mean agreement of an answer with the majority of the other answers (ties count ½): the
    /// accuracy a perfect model of the crowd could reach.
    pub noise_ceiling: Option<f64>,
    /// Median seconds per question (client-measured).
    pub median_seconds_per_question: Option<f64>,
    /// Answers per hour, oldest first (hours without answers are left out).
    pub answers_per_hour: Vec<HourCount>,
}

/// One bar of the control-error histogram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, ToSchema)]
pub struct ErrorCount {
    /// Wrong or unanswered controls in a HIT.
    pub errors: i64,
    /// Completed HITs with that many.
    pub count: i64,
}

/// The answers stored in one hour.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, ToSchema)]
pub struct HourCount {
    /// The hour's start (Unix ms, UTC).
    pub hour: i64,
    /// Answers stored in it.
    pub count: i64,
}

/// One row of the per-worker table: one worker's HIT in the study.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct WorkerRow {
    /// The worker's id on their crowd platform: MTurk `workerId`, Prolific `PROLIFIC_PID`, the
    /// `participant` of a direct link (what `blocked_workers` and every export name them by).
    pub worker_id: String,
    /// [`worker_id`](Self::worker_id) masked for the screen ([`mask`]).
    pub worker_id_masked: String,
    /// Assignment id.
    pub assignment: i64,
    /// `mturk`, `prolific`, `direct`.
    pub source: String,
    /// When the HIT started (Unix ms).
    pub started_at: i64,
    /// Assignment status.
    pub status: String,
    /// Current decision.
    pub decision: Option<String>,
    /// Training attempts.
    pub training_attempts: i64,
    /// Answered questions.
    pub answered: i64,
    /// Questions in the HIT.
    pub questions: i64,
    /// Wrong or unanswered controls.
    pub control_errors: i64,
    /// Median seconds per question.
    pub median_seconds: Option<f64>,
    /// Whether the worker id is on the study's block list.
    pub blocked: bool,
    /// Bonuses recorded for this HIT, in cents.
    pub bonus_cents: i64,
}

/// A worker id as the admin pages show it until clicked: enough to tell rows apart (the first
/// three and last two characters of a long id), not enough to copy the id from a shared screen.
pub fn mask(id: &str) -> String {
    let chars: Vec<char> = id.chars().collect();
    if chars.len() < 8 {
        return "\u{2022}".repeat(4);
    }
    let head: String = chars[..3].iter().collect();
    let tail: String = chars[chars.len() - 2..].iter().collect();
    format!("{head}\u{2026}{tail}")
}

fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    })
}

/// Agreement statistics of replicated answers: per tuple a list of answers (true = B).
/// Returns (tuples with ≥ 2 answers, agreement with the majority, leave-one-out noise ceiling).
pub fn agreement(by_tuple: &HashMap<i64, Vec<bool>>) -> (i64, Option<f64>, Option<f64>) {
    let (mut tuples, mut n, mut with_majority, mut loo) = (0i64, 0f64, 0f64, 0f64);
    for answers in by_tuple.values().filter(|a| a.len() >= 2) {
        tuples += 1;
        let b = answers.iter().filter(|&&x| x).count() as f64;
        let total = answers.len() as f64;
        for &x in answers {
            n += 1.0;
            let same = if x { b } else { total - b };
            let other = total - same;
            with_majority += if same > other {
                1.0
            } else if same == other {
                0.5
            } else {
                0.0
            };
            // The others: same - 1 agree with x, other disagree.
            let (agree, disagree) = (same - 1.0, other);
            loo += if agree > disagree {
                1.0
            } else if agree == disagree {
                0.5
            } else {
                0.0
            };
        }
    }
    if n == 0.0 {
        (0, None, None)
    } else {
        (tuples, Some(with_majority / n), Some(loo / n))
    }
}

/// Computes the dashboard and the per-worker table.
pub async fn compute(db: &Db, study: &Study) -> Result<(Dashboard, Vec<WorkerRow>)> {
    let mut d = Dashboard::default();
    let rows = sqlx::query(
        "SELECT a.id, w.external_id, a.source, a.started_at, a.status, a.decision, a.training_attempts, \
           (SELECT CAST(COUNT(*) AS BIGINT) FROM questions q WHERE q.assignment_id = a.id) AS questions, \
           (SELECT CAST(COUNT(*) AS BIGINT) FROM questions q WHERE q.assignment_id = a.id AND q.choice IS NOT NULL) AS answered, \
           (SELECT CAST(COUNT(*) AS BIGINT) FROM questions q JOIN tuples t ON t.id = q.tuple_id \
              WHERE q.assignment_id = a.id AND t.kind = 'control' \
              AND (q.choice IS NULL OR q.choice <> t.expected)) AS control_errors, \
           (SELECT CAST(COALESCE(SUM(b.amount_cents), 0) AS BIGINT) FROM bonuses b \
              WHERE b.assignment_id = a.id) AS bonus_cents \
         FROM assignments a JOIN workers w ON w.id = a.worker_id \
         WHERE a.study_id = $1 ORDER BY a.started_at DESC, a.id DESC",
    )
    .bind(study.id.0)
    .fetch_all(&db.pool)
    .await?;
    // The block list may hold many thousand ids: one set lookup per row.
    let blocked: HashSet<&str> = study
        .settings
        .blocked_workers
        .iter()
        .map(String::as_str)
        .collect();
    let mut workers = Vec::with_capacity(rows.len());
    let mut hist: BTreeMap<i64, i64> = BTreeMap::new();
    for r in &rows {
        let status: String = r.try_get("status")?;
        let decision: Option<String> = r.try_get("decision")?;
        d.started += 1;
        match status.as_str() {
            "training" => d.in_training += 1,
            "active" => d.active += 1,
            "completed" => d.completed += 1,
            "screened_out" => d.screened_out += 1,
            "declined" => d.declined += 1,
            "abandoned" => d.abandoned += 1,
            _ => {}
        }
        let errors: i64 = r.try_get("control_errors")?;
        if status == "completed" {
            *hist.entry(errors).or_default() += 1;
            match decision.as_deref() {
                Some("approved") => d.approved += 1,
                Some("rejected") => d.rejected += 1,
                _ => {}
            }
        }
        let worker_id: String = r.try_get("external_id")?;
        workers.push(WorkerRow {
            worker_id_masked: mask(&worker_id),
            blocked: blocked.contains(worker_id.as_str()),
            worker_id,
            assignment: r.try_get("id")?,
            source: r.try_get("source")?,
            started_at: r.try_get("started_at")?,
            status,
            decision,
            training_attempts: r.try_get("training_attempts")?,
            answered: r.try_get("answered")?,
            questions: r.try_get("questions")?,
            control_errors: errors,
            median_seconds: None,
            bonus_cents: r.try_get("bonus_cents")?,
        });
    }
    d.rejection_rate = (d.completed > 0).then(|| d.rejected as f64 / d.completed as f64);
    d.control_error_histogram = hist
        .into_iter()
        .map(|(errors, count)| ErrorCount { errors, count })
        .collect();

    let slots = sqlx::query(
        "SELECT CAST(COUNT(*) AS BIGINT) AS n, CAST(COUNT(assignment_id) AS BIGINT) AS claimed \
         FROM slots WHERE study_id = $1",
    )
    .bind(study.id.0)
    .fetch_one(&db.pool)
    .await?;
    d.slots = slots.try_get("n")?;
    d.slots_claimed = slots.try_get("claimed")?;

    let answers = sqlx::query(
        "SELECT q.assignment_id, q.tuple_id, q.choice, q.elapsed_ms, q.answered_at, t.kind, a.decision \
         FROM questions q JOIN tuples t ON t.id = q.tuple_id JOIN assignments a ON a.id = q.assignment_id \
         WHERE a.study_id = $1 AND q.choice IS NOT NULL",
    )
    .bind(study.id.0)
    .fetch_all(&db.pool)
    .await?;
    let mut by_tuple: HashMap<i64, Vec<bool>> = HashMap::new();
    let mut seconds = Vec::new();
    let mut per_assignment: HashMap<i64, Vec<f64>> = HashMap::new();
    let mut per_hour: BTreeMap<i64, i64> = BTreeMap::new();
    for r in &answers {
        let kind: String = r.try_get("kind")?;
        let decision: Option<String> = r.try_get("decision")?;
        let choice: String = r.try_get("choice")?;
        if let Some(ms) = r.try_get::<Option<i64>, _>("elapsed_ms")? {
            seconds.push(ms as f64 / 1000.0);
            per_assignment
                .entry(r.try_get("assignment_id")?)
                .or_default()
                .push(ms as f64 / 1000.0);
        }
        if let Some(at) = r.try_get::<Option<i64>, _>("answered_at")? {
            *per_hour.entry(at - at.rem_euclid(3_600_000)).or_default() += 1;
        }
        if kind == "main" {
            d.answers += 1;
            if decision.as_deref() != Some("rejected") {
                by_tuple
                    .entry(r.try_get("tuple_id")?)
                    .or_default()
                    .push(choice == "b");
            }
        }
    }
    let (replicated, with_majority, ceiling) = agreement(&by_tuple);
    d.replicated_tuples = replicated;
    d.agreement_with_majority = with_majority;
    d.noise_ceiling = ceiling;
    d.median_seconds_per_question = median(&mut seconds);
    d.answers_per_hour = per_hour
        .into_iter()
        .map(|(hour, count)| HourCount { hour, count })
        .collect();
    for w in &mut workers {
        if let Some(v) = per_assignment.get_mut(&w.assignment) {
            w.median_seconds = median(v);
        }
    }
    Ok((d, workers))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn agreement_of_unanimous_and_split_tuples() {
        let mut m = HashMap::new();
        m.insert(1, vec![true, true, true]);
        let (n, maj, ceil) = agreement(&m);
        assert_eq!((n, maj, ceil), (1, Some(1.0), Some(1.0)));
        m.insert(2, vec![true, false]);
        // Tuple 2: each answer ties with the majority (0.5) and disagrees with the other (0).
        let (n, maj, ceil) = agreement(&m);
        assert_eq!(n, 2);
        assert!((maj.unwrap_or(0.0) - 4.0 / 5.0).abs() < 1e-12);
        assert!((ceil.unwrap_or(0.0) - 3.0 / 5.0).abs() < 1e-12);
    }

    #[test]
    fn worker_ids_are_masked_for_the_screen() {
        assert_eq!(mask("A1B2C3D4E5F6G7"), "A1B\u{2026}G7");
        assert_eq!(mask("60ffe5c8371090c7041d43f8"), "60f\u{2026}f8");
        // Short ids would show most of themselves: fully masked.
        assert_eq!(mask("w1"), "\u{2022}\u{2022}\u{2022}\u{2022}");
        assert!(!mask("worker-1").contains("worker-1"));
    }

    #[test]
    fn medians() {
        assert_eq!(median(&mut []), None);
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), Some(2.5));
    }
}
