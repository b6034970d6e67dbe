//! Quality control: the control-question rule (a HIT with at least `reject_at_control_errors`
//! wrong hidden controls is rejected — Garces et al. 2014 §5.4 use 2 of 5), applied when a HIT
//! completes, re-playable as a dry run with another threshold, and overridable by an admin.
//! Every decision is a row in `decisions` (who, which rule, when, how many control errors).

use serde::Serialize;
use sqlx::Row;

use crate::error::{AppError, Result};
use crate::store::db::{Db, now_ms};
use crate::store::ids::{AssignmentId, DecisionId, StudyId};

/// The rule's name as recorded in the audit trail.
pub fn rule_name(threshold: u32) -> String {
    format!("control_errors>={threshold}")
}

/// Wrong or unanswered controls of assignment `$1`, as `n`.
const CONTROL_ERRORS: &str = "SELECT CAST(COUNT(*) AS BIGINT) AS n FROM questions q \
     JOIN tuples t ON t.id = q.tuple_id \
     WHERE q.assignment_id = $1 AND t.kind = 'control' \
     AND (q.choice IS NULL OR q.choice <> t.expected)";

/// [`control_errors`] on the SQLite answer writer's connection.
pub(crate) fn control_errors_sqlite(
    conn: &rusqlite::Connection,
    assignment: AssignmentId,
) -> Result<i64> {
    let n =
        crate::store::sqlite_direct::optional_row(conn, CONTROL_ERRORS, &[&assignment.0], |r| {
            r.get::<_, i64>(0)
        })?;
    Ok(n.unwrap_or(0))
}

/// Wrong or unanswered hidden controls of an assignment.
pub async fn control_errors(
    conn: &mut sqlx::AnyConnection,
    assignment: AssignmentId,
) -> Result<i64> {
    let row = sqlx::query(CONTROL_ERRORS)
        .bind(assignment.0)
        .fetch_one(&mut *conn)
        .await?;
    Ok(row.try_get("n")?)
}

/// The rule's verdict.
pub fn verdict(errors: i64, threshold: u32) -> &'static str {
    if errors >= i64::from(threshold) {
        "rejected"
    } else {
        "approved"
    }
}

/// The audit row of a decision (`$1` id … `$7` time, in the column order).
const INSERT_DECISION: &str = "INSERT INTO decisions \
     (id, assignment_id, decision, rule, actor, control_errors, decided_at) \
     VALUES ($1, $2, $3, $4, $5, $6, $7)";

/// The assignment's current decision.
const SET_DECISION: &str = "UPDATE assignments SET decision = $1 WHERE id = $2";

/// [`record`] on the SQLite answer writer's connection, inside its transaction.
pub(crate) fn record_sqlite(
    conn: &rusqlite::Connection,
    assignment: AssignmentId,
    decision: &str,
    rule: &str,
    actor: &str,
    errors: i64,
) -> Result<()> {
    use crate::store::sqlite_direct::execute;
    execute(
        conn,
        INSERT_DECISION,
        &[
            &DecisionId::generate().0,
            &assignment.0,
            &decision,
            &rule,
            &actor,
            &errors,
            &now_ms(),
        ],
    )?;
    execute(conn, SET_DECISION, &[&decision, &assignment.0])?;
    Ok(())
}

/// Records a decision inside `tx` and makes it the assignment's current one.
pub async fn record(
    tx: &mut sqlx::AnyConnection,
    assignment: AssignmentId,
    decision: &str,
    rule: &str,
    actor: &str,
    errors: i64,
) -> Result<()> {
    sqlx::query(INSERT_DECISION)
        .bind(DecisionId::generate().0)
        .bind(assignment.0)
        .bind(decision)
        .bind(rule)
        .bind(actor)
        .bind(errors)
        .bind(now_ms())
        .execute(&mut *tx)
        .await?;
    sqlx::query(SET_DECISION)
        .bind(decision)
        .bind(assignment.0)
        .execute(&mut *tx)
        .await?;
    Ok(())
}

/// What the rule says (or would say) about one completed assignment.
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct RuleOutcome {
    /// The assignment.
    pub assignment: AssignmentId,
    /// The worker's id on their crowd platform (as in the worker table and the exports).
    pub worker_id: String,
    /// `mturk`, `prolific` or `direct`.
    pub source: String,
    /// Wrong or unanswered controls.
    pub control_errors: i64,
    /// Its current decision.
    #[schema(value_type = Option<crate::web::api::quality::Decision>)]
    pub current: Option<String>,
    /// The rule's verdict.
    #[schema(value_type = crate::web::api::quality::Decision)]
    pub verdict: String,
    /// Whether applying would change the decision.
    pub changes: bool,
    /// Whether the current decision is an admin override (applying leaves it alone).
    pub overridden: bool,
}

/// Evaluates the rule with `threshold` on every completed assignment of `study` (the newest
/// first, as the worker table lists them); with `apply`, records the changed decisions (admin
/// overrides are kept).
pub async fn evaluate(
    db: &Db,
    study: StudyId,
    threshold: u32,
    apply: bool,
    actor: &str,
) -> Result<Vec<RuleOutcome>> {
    if threshold == 0 {
        return Err(AppError::BadRequest("threshold must be at least 1".into()));
    }
    let rows = sqlx::query(
        "SELECT a.id, a.decision, a.source, w.external_id, \
           (SELECT CAST(COUNT(*) AS BIGINT) FROM questions q JOIN tuples t ON t.id = q.tuple_id \
            WHERE q.assignment_id = a.id AND t.kind = 'control' \
            AND (q.choice IS NULL OR q.choice <> t.expected)) AS errors, \
           (SELECT d.actor FROM decisions d WHERE d.assignment_id = a.id \
            ORDER BY d.decided_at DESC, d.id DESC LIMIT 1) AS last_actor \
         FROM assignments a JOIN workers w ON w.id = a.worker_id \
         WHERE a.study_id = $1 AND a.status = 'completed' ORDER BY a.started_at DESC, a.id DESC",
    )
    .bind(study.0)
    .fetch_all(&db.pool)
    .await?;
    let mut out = Vec::with_capacity(rows.len());
    for r in rows {
        let errors: i64 = r.try_get("errors")?;
        let current: Option<String> = r.try_get("decision")?;
        let last_actor: Option<String> = r.try_get("last_actor")?;
        let overridden = last_actor.is_some_and(|a| a.starts_with("admin:"));
        let v = verdict(errors, threshold);
        out.push(RuleOutcome {
            assignment: AssignmentId(r.try_get("id")?),
            worker_id: r.try_get("external_id")?,
            source: r.try_get("source")?,
            control_errors: errors,
            changes: !overridden && current.as_deref() != Some(v),
            current,
            verdict: v.to_string(),
            overridden,
        });
    }
    if apply {
        let rule = rule_name(threshold);
        for o in out.iter().filter(|o| o.changes) {
            let mut tx = db.begin_write().await?;
            record(
                &mut tx,
                o.assignment,
                &o.verdict,
                &rule,
                actor,
                o.control_errors,
            )
            .await?;
            tx.commit().await?;
        }
    }
    Ok(out)
}

/// An admin's override of one assignment's decision.
pub async fn override_decision(
    db: &Db,
    study: StudyId,
    assignment: AssignmentId,
    decision: &str,
    admin: &str,
) -> Result<()> {
    if decision != "approved" && decision != "rejected" {
        return Err(AppError::BadRequest(
            "decision must be 'approved' or 'rejected'".into(),
        ));
    }
    let mut tx = db.begin_write().await?;
    let row = sqlx::query("SELECT status FROM assignments WHERE id = $1 AND study_id = $2")
        .bind(assignment.0)
        .bind(study.0)
        .fetch_optional(&mut *tx)
        .await?
        .ok_or(AppError::NotFound("assignment"))?;
    let status: String = row.try_get("status")?;
    if status != "completed" {
        return Err(AppError::Conflict(format!(
            "only completed assignments can be decided (this one is {status})"
        )));
    }
    let errors = control_errors(&mut tx, assignment).await?;
    record(
        &mut tx,
        assignment,
        decision,
        "override",
        &format!("admin:{admin}"),
        errors,
    )
    .await?;
    tx.commit().await?;
    Ok(())
}

/// One audited decision.
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct DecisionRecord {
    /// The assignment.
    pub assignment: AssignmentId,
    /// The worker's id on their crowd platform (as in the worker table and the exports).
    pub worker_id: String,
    /// `mturk`, `prolific` or `direct`.
    pub source: String,
    /// The decision.
    #[schema(value_type = crate::web::api::quality::Decision)]
    pub decision: String,
    /// The rule (`control_errors>=2`) or `override`.
    pub rule: String,
    /// `rule` or `admin:NAME`.
    pub actor: String,
    /// Control errors at the time.
    pub control_errors: i64,
    /// Unix ms.
    pub decided_at: i64,
}

/// The audit trail of a study, newest first.
pub async fn audit(db: &Db, study: StudyId) -> Result<Vec<DecisionRecord>> {
    let rows = sqlx::query(
        "SELECT d.assignment_id, d.decision, d.rule, d.actor, d.control_errors, d.decided_at, \
           a.source, w.external_id \
         FROM decisions d JOIN assignments a ON a.id = d.assignment_id \
           JOIN workers w ON w.id = a.worker_id \
         WHERE a.study_id = $1 ORDER BY d.decided_at DESC, d.id DESC",
    )
    .bind(study.0)
    .fetch_all(&db.pool)
    .await?;
    rows.iter()
        .map(|r| {
            Ok(DecisionRecord {
                assignment: AssignmentId(r.try_get("assignment_id")?),
                worker_id: r.try_get("external_id")?,
                source: r.try_get("source")?,
                decision: r.try_get("decision")?,
                rule: r.try_get("rule")?,
                actor: r.try_get("actor")?,
                control_errors: r.try_get("control_errors")?,
                decided_at: r.try_get("decided_at")?,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_rule() {
        assert_eq!(verdict(0, 2), "approved");
        assert_eq!(verdict(1, 2), "approved");
        assert_eq!(verdict(2, 2), "rejected");
        assert_eq!(rule_name(2), "control_errors>=2");
    }
}
