//! The icon-set study's report (§6.6): per condition, the mean time per set and the mean
//! deletions per set, each with its 95% interval from Student's t distribution with n − 1
//! degrees of freedom (`learner::stats::mean_interval`), n being the sets made in that
//! condition (pooled over workers). The thesis: 79 ± 20 s per set with the explorer (A) and
//! 108 ± 27 s with the search (B); 0.6 and 2.8 deletions per set. Only completed HITs that are
//! not rejected count. Beside them, each condition's mean style spread of a set (the mean
//! style distance between two of its icons, measured when it was finished), a check that the
//! sets are "in one style". A set's time runs from its start (the task opened, or the previous set
//! finished) to its finish, both times taken by the server.

use serde::Serialize;
use sqlx::Row;

use super::log::{self, replay};
use super::{Condition, IconsetSettings};
use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::store::ids::{AssignmentId, ItemId};
use crate::studies::study::Study;

/// The confidence level of the report's intervals.
pub const CONFIDENCE: f64 = 0.95;

/// One finished set of a completed HIT.
#[derive(Debug, Clone, PartialEq)]
pub struct SetRow {
    /// The HIT.
    pub assignment: AssignmentId,
    /// Its worker's condition.
    pub condition: Condition,
    /// The set's number, from 1.
    pub set: usize,
    /// When it started (Unix ms).
    pub started_at: i64,
    /// When it was finished (Unix ms).
    pub finished_at: i64,
    /// Seconds from its start to its finish.
    pub seconds: f64,
    /// Icons removed from it.
    pub deletions: usize,
    /// Searches made while it was the current set.
    pub searches: usize,
    /// Its icons, in the order of the study's labels.
    pub items: Vec<ItemId>,
    /// Its style spread (`log::spread`), when measured.
    pub spread: Option<f64>,
}

/// A mean with its 95% t interval.
#[derive(Debug, Clone, PartialEq, Serialize, utoipa::ToSchema)]
pub struct MeanStats {
    /// The mean.
    pub mean: f64,
    /// Half-width of the interval (the thesis's "±").
    pub half_width: f64,
    /// Lower end.
    pub low: f64,
    /// Upper end.
    pub high: f64,
    /// Standard deviation.
    pub sd: f64,
}

/// One condition's numbers.
#[derive(Debug, Clone, PartialEq, Serialize, utoipa::ToSchema)]
pub struct ConditionReport {
    /// A (the explorer) or B (the search ordered by style).
    pub condition: Condition,
    /// Completed HITs.
    pub workers: usize,
    /// Sets they made (the n of the intervals).
    pub sets: usize,
    /// Seconds per set (absent with fewer than two sets).
    pub seconds_per_set: Option<MeanStats>,
    /// Deletions per set (absent with fewer than two sets).
    pub deletions_per_set: Option<MeanStats>,
    /// Searches per set (absent with fewer than two sets).
    pub searches_per_set: Option<MeanStats>,
    /// The style spread of a set (the mean style distance between two of its icons, under
    /// the study's model): a check that the sets are "in one style" (absent with fewer than
    /// two sets measured).
    pub spread_per_set: Option<MeanStats>,
}

/// The report of an icon-set study: condition A then B.
#[derive(Debug, Clone, PartialEq, Serialize, utoipa::ToSchema)]
pub struct IconsetReport {
    /// The confidence level of the intervals (0.95).
    pub confidence: f64,
    /// Per condition.
    pub conditions: Vec<ConditionReport>,
}

fn stats(values: &[f64]) -> Result<Option<MeanStats>> {
    if values.len() < 2 {
        return Ok(None);
    }
    let i = learner::stats::mean_interval(values, CONFIDENCE)
        .map_err(|e| AppError::Internal(format!("icon-set report: {e}")))?;
    Ok(Some(MeanStats {
        mean: i.mean,
        half_width: i.half_width,
        low: i.low,
        high: i.high,
        sd: i.sd,
    }))
}

/// Summarises the sets per condition.
pub fn summarise(rows: &[SetRow]) -> Result<IconsetReport> {
    let mut conditions = Vec::new();
    for condition in [Condition::A, Condition::B] {
        let mine: Vec<&SetRow> = rows.iter().filter(|r| r.condition == condition).collect();
        let mut workers: Vec<AssignmentId> = mine.iter().map(|r| r.assignment).collect();
        workers.sort_unstable();
        workers.dedup();
        let of = |f: fn(&SetRow) -> f64| mine.iter().map(|r| f(r)).collect::<Vec<f64>>();
        conditions.push(ConditionReport {
            condition,
            workers: workers.len(),
            sets: mine.len(),
            seconds_per_set: stats(&of(|r| r.seconds))?,
            deletions_per_set: stats(&of(|r| r.deletions as f64))?,
            searches_per_set: stats(&of(|r| r.searches as f64))?,
            spread_per_set: stats(&mine.iter().filter_map(|r| r.spread).collect::<Vec<f64>>())?,
        });
    }
    Ok(IconsetReport {
        confidence: CONFIDENCE,
        conditions,
    })
}

/// The finished sets of `study`'s HITs, oldest HIT first: of completed, non-rejected HITs only,
/// or of every HIT with a condition when `all`.
pub async fn set_rows(db: &Db, study: &Study, all: bool) -> Result<Vec<SetRow>> {
    let settings = settings_of(study)?;
    let rows = sqlx::query(
        "SELECT c.assignment_id, c.condition, a.status, a.decision FROM iconset_conditions c \
         JOIN assignments a ON a.id = c.assignment_id WHERE c.study_id = $1 ORDER BY c.seq",
    )
    .bind(study.id.0)
    .fetch_all(&db.pool)
    .await?;
    let mut out = Vec::new();
    for r in rows {
        let status: String = r.try_get("status")?;
        let decision: Option<String> = r.try_get("decision")?;
        if !all && (status != "completed" || decision.as_deref() == Some("rejected")) {
            continue;
        }
        let assignment = AssignmentId(r.try_get("assignment_id")?);
        let condition = Condition::from_stored(&r.try_get::<String, _>("condition")?)?;
        let tray = replay(
            &settings.labels,
            settings.sets,
            &log::events(db, assignment).await?,
        );
        for s in &tray.sets {
            let (Some(started_at), Some(finished_at)) = (s.started_at, s.finished_at) else {
                continue;
            };
            out.push(SetRow {
                assignment,
                condition,
                set: s.index,
                started_at,
                finished_at,
                seconds: (finished_at - started_at) as f64 / 1000.0,
                deletions: s.deletions,
                searches: s.searches,
                items: s.slots.iter().flatten().copied().collect(),
                spread: s.spread,
            });
        }
    }
    Ok(out)
}

/// The study's `iconset` settings (an internal error for another kind of study).
pub fn settings_of(study: &Study) -> Result<&IconsetSettings> {
    study
        .settings
        .iconset
        .as_ref()
        .ok_or_else(|| AppError::Internal(format!("study {} has no iconset settings", study.id)))
}

/// The report of `study`.
pub async fn report(db: &Db, study: &Study) -> Result<IconsetReport> {
    summarise(&set_rows(db, study, false).await?)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(condition: Condition, assignment: i64, seconds: f64, deletions: usize) -> SetRow {
        SetRow {
            assignment: AssignmentId(assignment),
            condition,
            set: 1,
            started_at: 0,
            finished_at: (seconds * 1000.0) as i64,
            seconds,
            deletions,
            searches: 0,
            items: Vec::new(),
            spread: None,
        }
    }

    #[test]
    fn sets_are_pooled_per_condition_with_t_intervals() {
        let r = summarise(&[
            row(Condition::A, 1, 60.0, 0),
            row(Condition::A, 1, 80.0, 1),
            row(Condition::A, 2, 100.0, 2),
            row(Condition::B, 3, 50.0, 4),
        ])
        .unwrap();
        let a = &r.conditions[0];
        assert_eq!((a.condition, a.workers, a.sets), (Condition::A, 2, 3));
        // 60, 80, 100 s: mean 80, sd 20, t(0.975; 2) = 4.302652729749464 (SciPy 1.17.1).
        let t = a.seconds_per_set.as_ref().unwrap();
        assert!((t.mean - 80.0).abs() < 1e-12 && (t.sd - 20.0).abs() < 1e-12);
        let half = 4.302_652_729_749_464 * 20.0 / 3f64.sqrt();
        assert!((t.half_width - half).abs() < 1e-9, "{}", t.half_width);
        let d = a.deletions_per_set.as_ref().unwrap();
        assert!((d.mean - 1.0).abs() < 1e-12 && (d.sd - 1.0).abs() < 1e-12);
        let b = &r.conditions[1];
        assert_eq!((b.workers, b.sets), (1, 1));
        assert!(b.seconds_per_set.is_none(), "one set has no interval");
    }
}
