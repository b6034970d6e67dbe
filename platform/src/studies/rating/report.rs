//! The composition-rating study's report (Appendix 5.B): the rate at which each worker chose
//! the condition-A composition, the mean of these rates over workers, and the one-sample,
//! one-sided t-test of that mean against chance (0.5) with its effect size (Cohen's d) and the
//! mean's 95% confidence interval, all from `learner::stats`. The paper reports 67–69% for
//! coherence and 63–66% for preference, p < 0.01, effect sizes 1.4–2.4.
//!
//! Counted: answers to main pairs (never controls or practice) of completed HITs that quality
//! control did not reject.

use std::collections::BTreeMap;

use serde::Serialize;
use sqlx::Row;

use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::studies::kind::RatingQuestion;
use crate::studies::study::Study;

/// One worker's choices.
#[derive(Debug, Clone, PartialEq, Serialize, utoipa::ToSchema)]
pub struct WorkerRate {
    /// The worker (platform id).
    pub worker: i64,
    /// Main pairs answered.
    pub answers: i64,
    /// Of which the condition-A (style-sorted) composition was chosen.
    pub chose_a: i64,
    /// chose_a / answers.
    pub rate: f64,
}

/// The test over workers' rates (absent with fewer than two workers or no spread).
#[derive(Debug, Clone, PartialEq, Serialize, utoipa::ToSchema)]
pub struct RatingStats {
    /// t = (mean − 0.5) / (s/√n).
    pub t: f64,
    /// n − 1.
    pub df: f64,
    /// One-sided p-value (H1: workers choose A more often than chance).
    pub p: f64,
    /// Cohen's d, (mean − 0.5)/s.
    pub effect_size: f64,
    /// Standard deviation of the workers' rates.
    pub sd: f64,
    /// Lower end of the mean rate's 95% t interval.
    pub ci_low: f64,
    /// Upper end.
    pub ci_high: f64,
}

/// The report of a composition-rating study.
#[derive(Debug, Clone, PartialEq, Serialize, utoipa::ToSchema)]
pub struct RatingReport {
    /// The question asked.
    pub question: RatingQuestion,
    /// Workers counted.
    pub workers: usize,
    /// Main answers counted.
    pub answers: i64,
    /// Of which chose A.
    pub chose_a: i64,
    /// Mean over workers of their rate of choosing A (the paper's preference rate).
    pub mean_rate: Option<f64>,
    /// The t-test against 0.5.
    pub stats: Option<RatingStats>,
    /// Why `stats` is absent.
    pub note: Option<String>,
    /// Per worker.
    pub per_worker: Vec<WorkerRate>,
}

/// Computes the report from the stored answers.
pub async fn report(db: &Db, study: &Study) -> Result<RatingReport> {
    let rows = sqlx::query(
        "SELECT a.worker_id, q.choice FROM questions q \
         JOIN assignments a ON a.id = q.assignment_id \
         JOIN tuples t ON t.id = q.tuple_id \
         WHERE a.study_id = $1 AND t.kind = 'main' AND q.choice IS NOT NULL \
         AND a.status = 'completed' AND COALESCE(a.decision, '') <> 'rejected'",
    )
    .bind(study.id.0)
    .fetch_all(&db.pool)
    .await?;
    let mut by_worker: BTreeMap<i64, (i64, i64)> = BTreeMap::new();
    for r in &rows {
        let worker: i64 = r.try_get("worker_id")?;
        let choice: String = r.try_get("choice")?;
        let e = by_worker.entry(worker).or_default();
        e.0 += 1;
        e.1 += i64::from(choice == "b");
    }
    let per_worker: Vec<WorkerRate> = by_worker
        .into_iter()
        .map(|(worker, (answers, chose_a))| WorkerRate {
            worker,
            answers,
            chose_a,
            rate: chose_a as f64 / answers as f64,
        })
        .collect();
    let rates: Vec<f64> = per_worker.iter().map(|w| w.rate).collect();
    let mean_rate = (!rates.is_empty()).then(|| rates.iter().sum::<f64>() / rates.len() as f64);
    let (stats, note) =
        match learner::stats::one_sample_t_test(&rates, &learner::stats::TTestParams::default()) {
            Ok(t) => (
                Some(RatingStats {
                    t: t.t,
                    df: t.df,
                    p: t.p,
                    effect_size: t.effect_size,
                    sd: t.interval.sd,
                    ci_low: t.interval.low,
                    ci_high: t.interval.high,
                }),
                None,
            ),
            Err(
                e @ (learner::Error::NotEnoughData { .. } | learner::Error::ZeroVariance { .. }),
            ) => (None, Some(e.to_string())),
            Err(e) => return Err(AppError::internal(e)),
        };
    Ok(RatingReport {
        question: study.settings.question.unwrap_or_default(),
        workers: per_worker.len(),
        answers: per_worker.iter().map(|w| w.answers).sum(),
        chose_a: per_worker.iter().map(|w| w.chose_a).sum(),
        mean_rate,
        stats,
        note,
        per_worker,
    })
}
