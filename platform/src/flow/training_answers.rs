//! The practice questions of an assignment, the grading of an attempt and giving up.

use super::*;

/// The questions of an assignment's next training attempt.
pub async fn training_questions(db: &Db, a: &Assignment) -> Result<Vec<QuestionView>> {
    training::questions(db, &study::load(db, a.study).await?, a).await
}

/// One training answer.
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TrainingAnswer {
    /// The question's position.
    pub position: i64,
    /// The chosen item.
    pub choice: ItemId,
}

/// Feedback on one training answer.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct TrainingFeedback {
    /// The question's position.
    pub position: i64,
    /// Whether the answer was right.
    pub correct: bool,
    /// The right answer (training questions are not controls, so this may be shown).
    pub expected: ItemId,
}

/// The result of a training attempt.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct TrainingResult {
    /// All answers right: the HIT has started.
    pub passed: bool,
    /// Per-question feedback.
    pub feedback: Vec<TrainingFeedback>,
    /// Attempts used so far (including this one).
    pub attempts: i64,
    /// Attempts left before the worker is screened out.
    pub attempts_left: i64,
    /// The assignment's status after this attempt.
    pub status: String,
}

/// Scores a training attempt; all right → the HIT is allocated; too many attempts → screened out.
pub async fn submit_training(
    db: &Db,
    study: &Study,
    a: &Assignment,
    answers: &[TrainingAnswer],
) -> Result<TrainingResult> {
    if a.status != "training" {
        return Err(AppError::Conflict(format!(
            "training is over (assignment is {})",
            a.status
        )));
    }
    let tuples = training::next_attempt(db, study, a).await?;
    if answers.len() != tuples.len() {
        return Err(AppError::BadRequest(format!(
            "expected {} training answers, got {}",
            tuples.len(),
            answers.len()
        )));
    }
    let attempt = a.training_attempts + 1;
    let mut feedback = Vec::with_capacity(tuples.len());
    let mut tx = db.begin_write().await?;
    // Claim the attempt number first: a concurrent duplicate submit finds it taken.
    let bumped = sqlx::query(
        "UPDATE assignments SET training_attempts = $1 WHERE id = $2 AND status = 'training' \
         AND training_attempts = $3",
    )
    .bind(attempt)
    .bind(a.id.0)
    .bind(a.training_attempts)
    .execute(&mut *tx)
    .await?;
    if bumped.rows_affected() == 0 {
        return Err(AppError::Conflict(
            "this training attempt was already submitted".into(),
        ));
    }
    let now = now_ms();
    for (i, (t, _, b, c)) in tuples.iter().enumerate() {
        let answer = answers
            .iter()
            .find(|x| x.position == i as i64)
            .ok_or_else(|| AppError::BadRequest(format!("no answer for training question {i}")))?;
        if answer.choice.0 != *b && answer.choice.0 != *c {
            return Err(AppError::BadRequest(format!(
                "training question {i}: choice is not one of the two options"
            )));
        }
        let correct = answer.choice.0 == *b;
        sqlx::query(
            "INSERT INTO training_answers (assignment_id, attempt, tuple_id, choice, correct, answered_at) \
             VALUES ($1, $2, $3, $4, $5, $6)",
        )
        .bind(a.id.0)
        .bind(attempt)
        .bind(t.0)
        .bind(if correct { "b" } else { "c" })
        .bind(i64::from(correct))
        .bind(now)
        .execute(&mut *tx)
        .await?;
        feedback.push(TrainingFeedback {
            position: i as i64,
            correct,
            expected: ItemId(*b),
        });
    }
    let passed = feedback.iter().all(|f| f.correct);
    let max = i64::from(study.settings.max_training_attempts);
    let status = if passed {
        "training"
    } else if attempt >= max {
        sqlx::query(
            "UPDATE assignments SET status = 'screened_out', completed_at = $1 WHERE id = $2",
        )
        .bind(now)
        .bind(a.id.0)
        .execute(&mut *tx)
        .await?;
        "screened_out"
    } else {
        "training"
    };
    tx.commit().await?;
    let status = if passed {
        allocate(db, study, a.id, a.worker).await?;
        "active"
    } else {
        status
    };
    Ok(TrainingResult {
        passed,
        feedback,
        attempts: attempt,
        attempts_left: (max - attempt).max(0),
        status: status.into(),
    })
}

/// A worker gives up the training: screened out (paid a screen-out, not rejected).
pub async fn give_up(db: &Db, a: &Assignment) -> Result<()> {
    let done = sqlx::query(
        "UPDATE assignments SET status = 'screened_out', completed_at = $1 WHERE id = $2 \
         AND status = 'training'",
    )
    .bind(now_ms())
    .bind(a.id.0)
    .execute(&mut *db.write_conn().await?)
    .await?;
    if done.rows_affected() == 0 && a.status != "screened_out" {
        return Err(AppError::Conflict(format!(
            "only a worker in training can give up (assignment is {})",
            a.status
        )));
    }
    Ok(())
}
