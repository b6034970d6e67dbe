//! What a HIT started now would hold, for the start page: the settings' `questions_per_hit`
//! and `training_questions` are what a HIT holds at most. A HIT claims one free slot of each
//! of up to `questions_per_hit - controls_per_hit` tuples and adds up to `controls_per_hit` of
//! the study's control triplets, so it holds fewer questions when fewer tuples have a free slot
//! (the end of a study) or the study has fewer controls (a library without style labels has
//! none); an attempt of the training shows one block of the practice pool, none without one.

use sqlx::Row;

use super::training;
use crate::error::Result;
use crate::store::db::Db;
use crate::studies::study::Study;

/// The questions of a HIT and of a training attempt started now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HitOutlook {
    /// Questions of the HIT, controls included (0: no free slot left, a start is refused).
    pub questions: usize,
    /// Practice questions before it (0: no training gate).
    pub practice: usize,
}

/// What a HIT and the training started now would hold (the slots claimed meanwhile by other
/// workers aside). Reads at most `questions_per_hit` index entries per replica of the free
/// slots, not the whole pool.
pub async fn outlook(db: &Db, study: &Study) -> Result<HitOutlook> {
    let s = &study.settings;
    let wanted = i64::from(s.questions_per_hit - s.controls_per_hit);
    let free: i64 = sqlx::query(
        "SELECT CAST(COUNT(*) AS BIGINT) AS n FROM (SELECT seq FROM slots \
         WHERE study_id = $1 AND assignment_id IS NULL GROUP BY seq ORDER BY seq LIMIT $2) f",
    )
    .bind(study.id.0)
    .bind(wanted)
    .fetch_one(&db.pool)
    .await?
    .try_get("n")?;
    let controls: i64 = sqlx::query(
        "SELECT CAST(COUNT(*) AS BIGINT) AS n FROM tuples WHERE study_id = $1 AND kind = 'control'",
    )
    .bind(study.id.0)
    .fetch_one(&db.pool)
    .await?
    .try_get("n")?;
    let questions = if free == 0 {
        0
    } else {
        (free + controls.min(i64::from(s.controls_per_hit))) as usize
    };
    let pool = training::pool(db, study.id).await?;
    let practice = training::block(&pool, s.training_questions as usize, 0).len();
    Ok(HitOutlook {
        questions,
        practice,
    })
}
