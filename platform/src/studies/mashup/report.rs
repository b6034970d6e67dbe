//! The mash-up study's report (§5.7.3): per condition, the mean position of the pieces used in
//! submitted compositions — each piece's 1-based position in the result list it was dragged
//! from — with its 95% t interval (`learner::stats::mean_interval`), and the numbers of
//! workers, pieces and searches. The paper: 24 ± 4.4 with the metric (A), 40 ± 7.1 without
//! (B). Pieces are pooled over workers, as the paper reports a mean over the pieces used.

use serde::Serialize;
use sqlx::Row;

use super::Condition;
use super::log::{self, replay};
use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::store::ids::{AssignmentId, CompositionId, StudyId};

/// One submitted composition, as the report counts it.
#[derive(Debug, Clone, PartialEq)]
pub struct Submitted {
    /// Its worker's condition.
    pub condition: Condition,
    /// The positions of its pieces (one per piece).
    pub positions: Vec<i64>,
    /// Searches its worker made.
    pub searches: i64,
}

/// The mean position of one condition's pieces with its 95% interval.
#[derive(Debug, Clone, PartialEq, Serialize, utoipa::ToSchema)]
pub struct PositionStats {
    /// Mean 1-based position.
    pub mean: f64,
    /// Half-width of the 95% t interval (the paper's "±").
    pub half_width: f64,
    /// Lower end.
    pub low: f64,
    /// Upper end.
    pub high: f64,
    /// Standard deviation of the positions.
    pub sd: f64,
}

/// One condition's numbers.
#[derive(Debug, Clone, PartialEq, Serialize, utoipa::ToSchema)]
pub struct ConditionReport {
    /// A (style-sorted) or B (random order).
    pub condition: Condition,
    /// Workers who submitted a composition.
    pub workers: usize,
    /// Pieces in their compositions.
    pub pieces: usize,
    /// Searches they made.
    pub searches: i64,
    /// The mean position (absent with fewer than two pieces).
    pub position: Option<PositionStats>,
}

/// The report of a mash-up study: condition A then B.
#[derive(Debug, Clone, PartialEq, Serialize, utoipa::ToSchema)]
pub struct MashupReport {
    /// Per condition.
    pub conditions: Vec<ConditionReport>,
}

/// Summarises submitted compositions per condition.
pub fn summarise(submitted: &[Submitted]) -> Result<MashupReport> {
    let mut conditions = Vec::new();
    for condition in [Condition::A, Condition::B] {
        let mine: Vec<&Submitted> = submitted
            .iter()
            .filter(|s| s.condition == condition)
            .collect();
        let positions: Vec<f64> = mine
            .iter()
            .flat_map(|s| s.positions.iter().map(|&p| p as f64))
            .collect();
        let position = if positions.len() < 2 {
            None
        } else {
            let i = learner::stats::mean_interval(&positions, 0.95)
                .map_err(|e| AppError::Internal(format!("mash-up report: {e}")))?;
            Some(PositionStats {
                mean: i.mean,
                half_width: i.half_width,
                low: i.low,
                high: i.high,
                sd: i.sd,
            })
        };
        conditions.push(ConditionReport {
            condition,
            workers: mine.len(),
            pieces: positions.len(),
            searches: mine.iter().map(|s| s.searches).sum(),
            position,
        });
    }
    Ok(MashupReport { conditions })
}

/// The submitted compositions of `study`, with their pieces' logged positions.
pub async fn submitted(db: &Db, study: StudyId) -> Result<Vec<Submitted>> {
    let rows = sqlx::query(
        "SELECT c.assignment_id, c.condition, s.composition_id FROM mashup_conditions c \
         JOIN mashup_submissions s ON s.assignment_id = c.assignment_id \
         WHERE c.study_id = $1 ORDER BY c.seq",
    )
    .bind(study.0)
    .fetch_all(&db.pool)
    .await?;
    let mut out = Vec::with_capacity(rows.len());
    for r in rows {
        let assignment = AssignmentId(r.try_get("assignment_id")?);
        let condition = Condition::from_stored(&r.try_get::<String, _>("condition")?)?;
        // The submission was checked against the same events, so this cannot fail.
        let doc = crate::mashup::store::get(db, CompositionId(r.try_get("composition_id")?))
            .await?
            .document;
        let items: Vec<_> = doc.pieces.iter().map(|p| p.item).collect();
        let canvas = replay(&log::events(db, assignment).await?);
        let mut positions = log::positions(&items, &canvas)
            .map_err(|e| AppError::Internal(format!("assignment {assignment}: {e}")))?;
        positions.sort_unstable();
        out.push(Submitted {
            condition,
            positions,
            searches: log::search_count(db, assignment).await?,
        });
    }
    Ok(out)
}

/// The report of `study`.
pub async fn report(db: &Db, study: StudyId) -> Result<MashupReport> {
    summarise(&submitted(db, study).await?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_pools_pieces_per_condition() {
        let s = |condition, positions: &[i64], searches| Submitted {
            condition,
            positions: positions.to_vec(),
            searches,
        };
        let r = summarise(&[
            s(Condition::A, &[1, 3], 2),
            s(Condition::B, &[10], 1),
            s(Condition::A, &[5], 4),
        ])
        .unwrap();
        let a = &r.conditions[0];
        assert_eq!(
            (a.condition, a.workers, a.pieces, a.searches),
            (Condition::A, 2, 3, 6)
        );
        let p = a.position.as_ref().unwrap();
        // Positions 1, 3, 5: mean 3, sd 2, t(0.975; 2) = 4.302652729749464 (SciPy 1.17.1),
        // half-width 4.302652729749464 · 2 / √3.
        assert!((p.mean - 3.0).abs() < 1e-12);
        assert!((p.sd - 2.0).abs() < 1e-12);
        let half = 4.302_652_729_749_464 * 2.0 / 3f64.sqrt();
        assert!((p.half_width - half).abs() < 1e-9, "{}", p.half_width);
        let b = &r.conditions[1];
        assert_eq!((b.workers, b.pieces, b.searches), (1, 1, 1));
        assert!(b.position.is_none(), "one piece has no interval");
    }
}
